"""What the CP-SAT encoding is made of (encode.py builds it; docs/solvers.md): the rules that
can be switched off (:class:`Item`), the part of a timeline one solve decides (:class:`Frame`),
optional occurrences (:class:`Slot`), the built model with its handles (:class:`Encoding`) and
the literal helpers its users share.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal, Union

from mse.diagnostics import Span
from mse.ir import model as ir

if TYPE_CHECKING:
    from ortools.sat.python import cp_model
    from ortools.sat.python.cp_model_helper import Literal as CpLiteral

    Lit = Union[CpLiteral, bool]  # noqa: UP007 (a runtime-free alias)
    Edge = Union[cp_model.IntVar, int]  # noqa: UP007
else:
    Lit = object
    Edge = object

ItemKind = Literal["constraint", "duration", "occurrence rule", "pin", "require", "forbid", "keep"]


@dataclass(frozen=True, slots=True)
class Item:
    """One rule that can be switched off: what an explanation is made of."""

    id: str
    kind: ItemKind
    span: Span
    text: str


@dataclass(frozen=True)
class Frame:
    """The part of a timeline one solve decides (the rolling horizon of docs/solvers.md).

    *Window* slots decide the occurrences that start in ``[begin, end)``; a once-only
    signal's one slot may also start later (its "later" option).  *Later* slots of
    repetitive signals (``later`` per signal) start in ``[end, duration]``: they are not
    kept, they only prove that the timeline can still be completed.  ``past`` holds the
    committed occurrences that still matter (per signal its first and its last: see
    :mod:`mse.solve.cpsat.horizon`), ``committed`` how many occurrences each signal already
    has, and ``falsified`` the atoms that committed occurrences already make false.
    The default frame is a whole timeline decided at once."""

    begin: int = 0
    end: int | None = None
    past: Mapping[str, tuple[tuple[int, int], ...]] = field(default_factory=dict)
    committed: Mapping[str, int] = field(default_factory=dict)
    falsified: frozenset[ir.Atom] = frozenset()
    later: Mapping[str, int] = field(default_factory=dict)


@dataclass(slots=True)
class Slot:
    """One optional occurrence.  ``group`` is "past" (a committed occurrence: constant
    times, ``present`` True), "window" or "later"."""

    signal: str
    index: int
    present: Any  # a CP-SAT literal; True for a committed occurrence
    start: Any  # CP-SAT variables; ints for a committed occurrence
    stop: Any
    length: Any
    group: str = "window"

    @property
    def decided(self) -> bool:
        return self.group != "past"


def var(edge: Edge) -> cp_model.IntVar:
    """The variable of a decided slot's edge (a committed slot's edges are constants)."""
    assert not isinstance(edge, int), "a committed occurrence has no variables"
    return edge


@dataclass(frozen=True, slots=True)
class Time:
    """``var + const`` (var None: a constant)."""

    var: cp_model.IntVar | None
    const: int


def time_of_edge(edge: Edge, offset: int = 0) -> Time:
    if isinstance(edge, int):
        return Time(None, edge + offset)
    return Time(edge, offset)


@dataclass
class Encoding:
    """A built CP-SAT model and the handles the solver, explainer and linter need."""

    cp: cp_model.CpModel
    model: ir.Model
    duration: int
    slots: dict[str, list[Slot]]
    occurs: dict[str, Lit]
    frame: Frame = field(default_factory=Frame)
    instantiated: dict[str, Lit] = field(default_factory=dict)
    violated: dict[str, Lit] = field(default_factory=dict)
    enable: dict[str, cp_model.IntVar] = field(default_factory=dict)  # item key -> literal
    items: dict[str, Item] = field(default_factory=dict)  # item key -> item

    def decided(self, signal_id: str) -> list[Slot]:
        """The slots of ``signal_id`` this solve decides (window and later ones)."""
        return [slot for slot in self.slots[signal_id] if slot.decided]


def lnot(literal: Lit) -> Lit:
    if isinstance(literal, bool):
        return not literal
    return ~literal

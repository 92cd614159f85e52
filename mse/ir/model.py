"""The resolved, typed model of one MSE expression.

Built from the AST by :mod:`mse.ir.build`; every name is resolved and every number
validated.  Times in constraints are integer milliseconds (the 1 ms grid of the
semantics), durations of signals are kept in seconds for display and converted with
:func:`mse.ir.schedule.to_ticks` where solvers need ticks.  Source spans never take part in
equality, so two constraints that say the same thing compare equal.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from functools import cached_property
from typing import Literal

from mse.diagnostics import Span

NO_SPAN = Span("<none>")

KNOWN_MODALITIES: frozenset[str] = frozenset({"face", "head", "gaze", "gesture", "torso", "posture", "speech"})

Edge = Literal["start", "stop"]
RelationKind = Literal["includes", "excludes", "precedes", "rightincludes"]
CompareOp = Literal["<", ">", "=", "<=", ">="]
Anchor = Literal["start", "stop", "stressed_start", "stressed_stop"]


# -- terms ------------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class SignalTime:
    """``start(s) + offset`` or ``stop(s) + offset`` (offset in ms)."""

    signal: str
    edge: Edge
    offset: int = 0
    span: Span = field(default=NO_SPAN, compare=False, repr=False)


@dataclass(frozen=True, slots=True)
class DurationTime:
    """``duration + offset``: the requested length of the timeline (offset in ms)."""

    offset: int = 0
    span: Span = field(default=NO_SPAN, compare=False, repr=False)


@dataclass(frozen=True, slots=True)
class Constant:
    """A number of milliseconds."""

    value: int
    span: Span = field(default=NO_SPAN, compare=False, repr=False)


@dataclass(frozen=True, slots=True)
class SpeechTime:
    """A time of the agent's speech plus an offset (ms): the utterance's ``start`` or ``stop``
    (``speech.start``, ``speech.stop``), or the start or stop of a stressed word
    (``stressed``, ``stressed.stop``).  Known only with the request's speech:
    :func:`mse.ir.anchors.resolve_anchors` rewrites it into constants before any solver or
    the evaluator sees the model (docs/semantics.md, "Speech anchors")."""

    anchor: Anchor
    offset: int = 0
    span: Span = field(default=NO_SPAN, compare=False, repr=False)


Term = SignalTime | DurationTime | SpeechTime | Constant


# -- atoms and connectives ----------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class Exists:
    signal: str
    span: Span = field(default=NO_SPAN, compare=False, repr=False)


@dataclass(frozen=True, slots=True)
class Relation:
    """includes / excludes / precedes / rightincludes between two signals."""

    kind: RelationKind
    left: str
    right: str
    span: Span = field(default=NO_SPAN, compare=False, repr=False)


@dataclass(frozen=True, slots=True)
class Compare:
    """``left op right``; for ``=`` a tolerance in ms (``equal(x, y, tol)``)."""

    op: CompareOp
    left: Term
    right: Term
    tolerance: int = 0
    span: Span = field(default=NO_SPAN, compare=False, repr=False)


@dataclass(frozen=True, slots=True)
class Not:
    operand: Expr
    span: Span = field(default=NO_SPAN, compare=False, repr=False)


@dataclass(frozen=True, slots=True)
class And:
    operands: tuple[Expr, ...]
    span: Span = field(default=NO_SPAN, compare=False, repr=False)


@dataclass(frozen=True, slots=True)
class Or:
    operands: tuple[Expr, ...]
    span: Span = field(default=NO_SPAN, compare=False, repr=False)


@dataclass(frozen=True, slots=True)
class Implies:
    left: Expr
    right: Expr
    span: Span = field(default=NO_SPAN, compare=False, repr=False)


Atom = Exists | Relation | Compare
Expr = Exists | Relation | Compare | Not | And | Or | Implies


def children(expr: Expr) -> tuple[Expr, ...]:
    if isinstance(expr, Not):
        return (expr.operand,)
    if isinstance(expr, And | Or):
        return expr.operands
    if isinstance(expr, Implies):
        return (expr.left, expr.right)
    return ()


def walk(expr: Expr) -> Iterator[Expr]:
    """Every node of ``expr``, pre-order (iterative: deep trees do not recurse)."""
    stack: list[Expr] = [expr]
    while stack:
        node = stack.pop()
        yield node
        stack.extend(reversed(children(node)))


def term_signals(term: Term) -> tuple[str, ...]:
    return (term.signal,) if isinstance(term, SignalTime) else ()


def atom_signals(atom: Atom) -> tuple[str, ...]:
    if isinstance(atom, Exists):
        return (atom.signal,)
    if isinstance(atom, Relation):
        return (atom.left, atom.right)
    return term_signals(atom.left) + term_signals(atom.right)


def trigger_signals(expr: Expr) -> frozenset[str]:
    """Signals named in the relational atoms of ``expr`` (everything but ``exists``)."""
    found: set[str] = set()
    for node in walk(expr):
        if isinstance(node, Relation | Compare):
            found.update(atom_signals(node))
    return frozenset(found)


def mentioned_signals(expr: Expr) -> frozenset[str]:
    found: set[str] = set()
    for node in walk(expr):
        if isinstance(node, Exists | Relation | Compare):
            found.update(atom_signals(node))
    return frozenset(found)


# -- declarations -------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class MotionLeaf:
    """``<motion action=... [clip] [nd] [states] [method]/>``: a body signal's motion."""

    action: str
    clip: str | None = None
    nd: int = 0
    states: int = 12
    method: str = "lma-hmm"
    attributes: Mapping[str, str] = field(default_factory=dict, compare=False)
    span: Span = field(default=NO_SPAN, compare=False, repr=False)


@dataclass(frozen=True, slots=True)
class Signal:
    """A signal with the paper's five characteristics (defaults are Greta's)."""

    id: str
    modality: str
    lexeme: str
    min_duration: float = 0.0
    max_duration: float | None = None
    probability_start: float = 1.0
    probability_end: float = 1.0
    repetitivity: int = 0
    max_occurrences: int | None = None
    motion: MotionLeaf | None = None
    span: Span = field(default=NO_SPAN, compare=False, repr=False)
    #: How strongly the signal is shown, in [0, 1] (an occurrence's intensity is its episode's
    #: times this; mse.envelope).  Does not change where it occurs.
    intensity: float = 1.0

    @property
    def repetitive(self) -> bool:
        return self.repetitivity == 1


@dataclass(frozen=True)
class Constraint:
    """One constraint; ``id`` is the author's or ``c<N>`` (N = 1-based position)."""

    id: str
    expr: Expr
    explicit_id: bool = True
    text: str = field(default="", compare=False)  # as written in the file
    span: Span = field(default=NO_SPAN, compare=False, repr=False)

    @cached_property
    def triggers(self) -> frozenset[str]:
        return trigger_signals(self.expr)


@dataclass(frozen=True, slots=True)
class Modality:
    name: str
    exclusive: bool
    span: Span = field(default=NO_SPAN, compare=False, repr=False)


@dataclass(frozen=True)
class Model:
    """A resolved expression: signals, constraints and exclusive modalities."""

    name: str
    signals: tuple[Signal, ...]
    constraints: tuple[Constraint, ...] = ()
    modalities: tuple[Modality, ...] = ()
    description: str = ""
    path: str = "<memory>"

    @cached_property
    def signal_by_id(self) -> Mapping[str, Signal]:
        return {s.id: s for s in self.signals}

    def signal(self, signal_id: str) -> Signal:
        return self.signal_by_id[signal_id]

    @cached_property
    def exclusive_modalities(self) -> frozenset[str]:
        return frozenset(m.name for m in self.modalities if m.exclusive)

    @cached_property
    def signal_info(self) -> Mapping[str, tuple[str, str]]:
        """id -> (modality, lexeme), as :func:`mse.timeline.from_schedule` wants it."""
        return {s.id: (s.modality, s.lexeme) for s in self.signals}

    @cached_property
    def motion_annotations(self) -> Mapping[str, Mapping[str, str]]:
        """id -> ``{"action": ...}`` for every motion-leaf signal (timeline entries carry it).

        >>> from mse.api import load
        >>> load("embarrassment").motion_annotations["bow"]
        {'action': 'bow'}
        """
        return {s.id: {"action": s.motion.action} for s in self.signals if s.motion is not None}

"""The exact CP-SAT encoding of a model (docs/solvers.md; the law is docs/semantics.md).

Every signal gets a few *slots* (optional occurrences, :mod:`mse.solve.bounds`):
a presence literal and integer start/stop on the 1 ms grid.  Slots of one signal are
ordered and non-overlapping (slot i+1 present implies slot i present and starts after it
stops), which also breaks the symmetry between them; an absent slot is pinned to [0, 0]
so that every timeline has exactly one assignment (enumeration counts schedules).

Three-valued logic uses two literals per node, *is-true* and *is-false* (both false:
unknown); ``not`` swaps them, ``and``/``or`` are the strong Kleene tables.  A relational
atom is false iff some combination of present occurrences falsifies it, and true iff all
its signals occur and it is not false.  A constraint is violated iff it is instantiated
(no trigger signals, or one of them occurs) and false.

With ``switchable=True`` every rule a user can be blamed for (each constraint, each
signal's duration bounds, each exclusive modality, each pin, require and forbid) is
guarded by an *enable* literal, so that explanations and lint can switch rules on and off
with assumptions instead of rebuilding the model.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal, Union

from mse.diagnostics import Span
from mse.ir import model as ir
from mse.ir.schedule import to_ticks
from mse.solve.bounds import length_bounds
from mse.solve.protocol import Pin

if TYPE_CHECKING:
    from ortools.sat.python import cp_model
    from ortools.sat.python.cp_model_helper import Literal as CpLiteral

    Lit = Union[CpLiteral, bool]  # noqa: UP007 (a runtime-free alias)
else:
    Lit = object

ItemKind = Literal["constraint", "duration", "occurrence rule", "pin", "require", "forbid"]


@dataclass(frozen=True, slots=True)
class Item:
    """One rule that can be switched off: what an explanation is made of."""

    id: str
    kind: ItemKind
    span: Span
    text: str


@dataclass(slots=True)
class Slot:
    signal: str
    index: int
    present: cp_model.IntVar
    start: cp_model.IntVar
    stop: cp_model.IntVar
    length: cp_model.IntVar


@dataclass(frozen=True, slots=True)
class _Time:
    """``var + const`` (var None: a constant)."""

    var: cp_model.IntVar | None
    const: int


@dataclass
class Encoding:
    """A built CP-SAT model and the handles the solver, explainer and linter need."""

    cp: cp_model.CpModel
    model: ir.Model
    duration: int
    slots: dict[str, list[Slot]]
    occurs: dict[str, Lit]
    instantiated: dict[str, Lit] = field(default_factory=dict)
    violated: dict[str, Lit] = field(default_factory=dict)
    enable: dict[str, cp_model.IntVar] = field(default_factory=dict)  # item key -> literal
    items: dict[str, Item] = field(default_factory=dict)  # item key -> item


class _Builder:
    def __init__(self, model: ir.Model, duration: int, switchable: bool) -> None:
        from ortools.sat.python import cp_model

        self.cp = cp_model.CpModel()
        self.model = model
        self.duration = duration
        self.switchable = switchable
        self.enc = Encoding(self.cp, model, duration, {}, {})
        self._le_cache: dict[tuple[int, int, int], Lit] = {}
        self._atom_cache: dict[ir.Atom, tuple[Lit, Lit]] = {}

    # -- literal helpers (constants folded so that trivial parts add nothing) -----------
    def land(self, literals: Sequence[Lit]) -> Lit:
        if any(lit is False for lit in literals):
            return False
        rest = list(dict.fromkeys(lit for lit in literals if lit is not True))
        if not rest:
            return True
        if len(rest) == 1:
            return rest[0]
        both = self.cp.new_bool_var("")
        self.cp.add_bool_and(rest).only_enforce_if(both)
        self.cp.add_bool_or([lnot(lit) for lit in rest]).only_enforce_if(lnot(both))
        return both

    def lor(self, literals: Sequence[Lit]) -> Lit:
        return lnot(self.land([lnot(lit) for lit in literals]))

    def guard(self, key: str, item: Item) -> Lit:
        """The enable literal of a switchable rule (True when rules are hard)."""
        if not self.switchable:
            return True
        literal = self.cp.new_bool_var(key)
        self.enc.enable[key] = literal
        self.enc.items[key] = item
        return literal

    def require_not(self, literal: Lit, enabled: Lit) -> None:
        """``enabled`` implies ``not literal``."""
        clause = [lit for lit in (lnot(literal), lnot(enabled)) if lit is not False]
        if any(lit is True for lit in clause):
            return
        self.cp.add_bool_or(clause)

    # -- occurrences ----------------------------------------------------------------------
    def add_slots(self, counts: Mapping[str, int], step: int) -> None:
        duration = self.duration
        for signal in self.model.signals:
            low, high = length_bounds(signal, duration)
            slots: list[Slot] = []
            count = counts.get(signal.id, 0)
            bounded = signal.min_duration > 0 or signal.max_duration is not None
            rule: Lit = True
            if bounded and count:
                upper = "inf" if signal.max_duration is None else f"{signal.max_duration:g}"
                rule = self.guard(f"duration:{signal.id}", Item(
                    signal.id, "duration", signal.span,
                    f"{signal.id} lasts between {signal.min_duration:g} and {upper} s"))
            for index in range(count):
                present = self.cp.new_bool_var(f"{signal.id}#{index}")
                start = self.cp.new_int_var(0, duration, "")
                stop = self.cp.new_int_var(0, duration, "")
                if step > 1:
                    for var in (start, stop):
                        cell = self.cp.new_int_var(0, duration // step, "")
                        self.cp.add(var == step * cell)
                length = self.cp.new_int_var(0, duration, "")
                self.cp.add(length == stop - start)
                self.cp.add(length >= 1).only_enforce_if(present)
                if rule is True:
                    self.cp.add(length >= low).only_enforce_if(present)
                    self.cp.add(length <= high).only_enforce_if(present)
                else:
                    self.cp.add(length >= low).only_enforce_if([present, rule])
                    self.cp.add(length <= high).only_enforce_if([present, rule])
                self.cp.add(start == 0).only_enforce_if(~present)
                self.cp.add(stop == 0).only_enforce_if(~present)
                if slots:
                    previous = slots[-1]
                    self.cp.add_implication(present, previous.present)
                    self.cp.add(start >= previous.stop).only_enforce_if(present)
                slots.append(Slot(signal.id, index, present, start, stop, length))
            self.enc.slots[signal.id] = slots
            self.enc.occurs[signal.id] = slots[0].present if slots else False

    def add_exclusive_modalities(self) -> None:
        for modality in self.model.modalities:
            if not modality.exclusive:
                continue
            members = [slot for s in self.model.signals if s.modality == modality.name
                       for slot in self.enc.slots[s.id]]
            if len({slot.signal for slot in members}) < 2:
                continue
            rule = self.guard(f"modality:{modality.name}", Item(
                modality.name, "occurrence rule", modality.span,
                f"signals of modality {modality.name!r} never overlap"))
            intervals = []
            actives: list[Lit] = []
            for slot in members:
                active = slot.present if rule is True else self.land([slot.present, rule])
                actives.append(active)
                intervals.append(self.cp.new_optional_interval_var(
                    slot.start, slot.length, slot.stop, active, ""))
            self.cp.add_no_overlap(intervals)
            # The same rule once more as pairwise "one before the other" literals (shared
            # with the relational atoms): NoOverlap alone cannot refute two equal-length
            # occurrences forced onto each other without trying every start time.
            for i, first in enumerate(members):
                for j in range(i + 1, len(members)):
                    second = members[j]
                    if first.signal == second.signal:
                        continue
                    before = self.le(_Time(first.stop, 0), _Time(second.start, 0))
                    after = self.le(_Time(second.stop, 0), _Time(first.start, 0))
                    clause = [before, after, lnot(actives[i]), lnot(actives[j])]
                    if not any(lit is True for lit in clause):
                        self.cp.add_bool_or([lit for lit in clause if lit is not False])

    # -- terms, atoms and connectives -----------------------------------------------------
    def le(self, left: _Time, right: _Time, bound: int = 0) -> Lit:
        """The literal of ``left - right <= bound``."""
        if left.var is right.var:
            return left.const - right.const <= bound
        key = (
            -1 if left.var is None else left.var.index,
            -1 if right.var is None else right.var.index,
            bound - left.const + right.const,
        )
        cached = self._le_cache.get(key)
        if cached is not None:
            return cached
        expression = (0 if left.var is None else left.var) - (0 if right.var is None else right.var)
        limit = key[2]
        holds = self.cp.new_bool_var("")
        self.cp.add(expression <= limit).only_enforce_if(holds)
        self.cp.add(expression >= limit + 1).only_enforce_if(~holds)
        self._le_cache[key] = holds
        return holds

    def time(self, term: ir.Term, chosen: Mapping[str, Slot]) -> _Time:
        if isinstance(term, ir.SignalTime):
            slot = chosen[term.signal]
            return _Time(slot.start if term.edge == "start" else slot.stop, term.offset)
        if isinstance(term, ir.DurationTime):
            return _Time(None, self.duration + term.offset)
        return _Time(None, term.value)

    def holds(self, atom: ir.Relation | ir.Compare, chosen: Mapping[str, Slot]) -> Lit:
        if isinstance(atom, ir.Relation):
            a, b = chosen[atom.left], chosen[atom.right]
            sa, ea, sb, eb = (_Time(v, 0) for v in (a.start, a.stop, b.start, b.stop))
            if atom.kind == "includes":
                return self.land([self.le(sa, sb), self.le(eb, ea)])
            if atom.kind == "excludes":
                return self.lor([self.le(ea, sb), self.le(eb, sa)])
            if atom.kind == "precedes":
                return self.le(ea, sb)
            return self.land([self.le(sa, eb), self.le(eb, ea)])
        left, right = self.time(atom.left, chosen), self.time(atom.right, chosen)
        if atom.op == "<":
            return self.le(left, right, -1)
        if atom.op == "<=":
            return self.le(left, right)
        if atom.op == ">":
            return self.le(right, left, -1)
        if atom.op == ">=":
            return self.le(right, left)
        return self.land([self.le(left, right, atom.tolerance), self.le(right, left, atom.tolerance)])

    def atom(self, atom: ir.Atom) -> tuple[Lit, Lit]:
        cached = self._atom_cache.get(atom)
        if cached is not None:
            return cached
        if isinstance(atom, ir.Exists):
            occurs = self.enc.occurs[atom.signal]
            result = (occurs, lnot(occurs))
        else:
            names = tuple(dict.fromkeys(ir.atom_signals(atom)))
            falsified: list[Lit] = []
            for combination in itertools.product(*(self.enc.slots[n] for n in names)):
                chosen = dict(zip(names, combination, strict=True))
                present = [slot.present for slot in combination]
                falsified.append(self.land([*present, lnot(self.holds(atom, chosen))]))
            is_false = self.lor(falsified)
            is_true = self.land([*(self.enc.occurs[n] for n in names), lnot(is_false)])
            result = (is_true, is_false)
        self._atom_cache[atom] = result
        return result

    def expr(self, expr: ir.Expr) -> tuple[Lit, Lit]:
        """(is-true, is-false) of ``expr``."""
        if isinstance(expr, ir.Not):
            true, false = self.expr(expr.operand)
            return false, true
        if isinstance(expr, ir.And | ir.Or):
            parts = [self.expr(e) for e in expr.operands]
            trues, falses = [p[0] for p in parts], [p[1] for p in parts]
            if isinstance(expr, ir.And):
                return self.land(trues), self.lor(falses)
            return self.lor(trues), self.land(falses)
        if isinstance(expr, ir.Implies):
            left_true, left_false = self.expr(expr.left)
            right_true, right_false = self.expr(expr.right)
            return self.lor([left_false, right_true]), self.land([left_true, right_false])
        return self.atom(expr)

    def add_constraints(self, enforce: bool) -> None:
        for constraint in self.model.constraints:
            triggers = sorted(constraint.triggers)
            instantiated = self.lor([self.enc.occurs[t] for t in triggers]) if triggers else True
            _, is_false = self.expr(constraint.expr)
            violated = self.land([instantiated, is_false])
            self.enc.instantiated[constraint.id] = instantiated
            self.enc.violated[constraint.id] = violated
            if not enforce:
                continue
            rule = self.guard(f"constraint:{constraint.id}", Item(
                constraint.id, "constraint", constraint.span, constraint.text or constraint.id))
            self.require_not(violated, rule)

    # -- request rules ----------------------------------------------------------------------
    def add_request(self, pins: Sequence[Pin], require: Sequence[str], forbid: Sequence[str]) -> None:
        where = Span("<arguments>")
        for number, pin in enumerate(pins):
            start, stop = to_ticks(pin.start), to_ticks(pin.stop)
            text = f"{pin.signal} pinned at {pin.start:g}-{pin.stop:g} s"
            rule = self.guard(f"pin:{number}", Item(pin.signal, "pin", where, text))
            choices: list[Lit] = []
            for slot in self.enc.slots[pin.signal]:
                if not 0 <= start < stop <= self.duration:
                    break
                here = self.cp.new_bool_var("")
                self.cp.add_implication(here, slot.present)
                self.cp.add(slot.start == start).only_enforce_if(here)
                self.cp.add(slot.stop == stop).only_enforce_if(here)
                choices.append(here)
            self.require_not(lnot(self.lor(choices)), rule)
        for signal in require:
            rule = self.guard(f"require:{signal}", Item(signal, "require", where, f"{signal} required"))
            self.require_not(lnot(self.enc.occurs[signal]), rule)
        for signal in forbid:
            rule = self.guard(f"forbid:{signal}", Item(signal, "forbid", where, f"{signal} forbidden"))
            self.require_not(self.enc.occurs[signal], rule)


def lnot(literal: Lit) -> Lit:
    if isinstance(literal, bool):
        return not literal
    return ~literal


def build(
    model: ir.Model,
    duration: int,
    counts: Mapping[str, int],
    *,
    switchable: bool = False,
    constraints: bool = True,
    step: int = 1,
    pins: Sequence[Pin] = (),
    require: Sequence[str] = (),
    forbid: Sequence[str] = (),
) -> Encoding:
    """Encode ``model`` for a timeline of ``duration`` ticks with ``counts`` slots per signal.

    ``constraints=False`` leaves constraints unenforced (the paper's constraint-less mode;
    their literals still exist for lint); ``step`` > 1 restricts times to that grid."""
    builder = _Builder(model, duration, switchable)
    builder.add_slots(counts, step)
    builder.add_exclusive_modalities()
    builder.add_constraints(constraints)
    builder.add_request(pins, require, forbid)
    return builder.enc

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
from typing import TYPE_CHECKING, Any

from mse.diagnostics import Span
from mse.ir import model as ir
from mse.ir.relations import COMPARISONS, RELATIONS, Endpoint, known_time
from mse.ir.schedule import to_ticks
from mse.solve.bounds import length_bounds
from mse.solve.cpsat.encoding import Edge, Encoding, Frame, Item, ItemKind, Lit, Slot, Time, lnot, time_of_edge, var
from mse.solve.protocol import Pin

if TYPE_CHECKING:
    from ortools.sat.python import cp_model

# The encoding's data and literal helpers live in encoding.py; importers keep taking them from here.
__all__ = ["Edge", "Encoding", "Frame", "Item", "ItemKind", "Lit", "Slot", "build", "lnot", "var"]


_MODEL_CLASS: Any = None


def _model_class(cp_model: Any) -> Any:
    """``CpModel`` without its per-instance camelCase aliases: OR-Tools 9.15 adds one
    deprecated alias per method to every new model (4 ms each), which dominated lint's
    many small local models.  We only use the snake_case names."""
    global _MODEL_CLASS
    if _MODEL_CLASS is None:
        class Model(cp_model.CpModel):  # type: ignore[misc]
            def _add_pre_pep8_methods(self) -> None:
                pass

        _MODEL_CLASS = Model
    return _MODEL_CLASS


class _Builder:
    def __init__(self, model: ir.Model, duration: int, switchable: bool, frame: Frame) -> None:
        from ortools.sat.python import cp_model

        self.cp: cp_model.CpModel = _model_class(cp_model)()
        self.model = model
        self.duration = duration
        self.switchable = switchable
        self.frame = frame
        self.end = duration if frame.end is None else frame.end
        self.enc = Encoding(self.cp, model, duration, {}, {}, frame)
        self._le_cache: dict[tuple[int, int, int], Lit] = {}
        self._atom_cache: dict[ir.Atom, tuple[Lit, Lit]] = {}
        self._related: frozenset[tuple[str, str]] | None = None

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
    def _new_slot(self, signal: ir.Signal, index: int, group: str, step: int, rule: Lit,
                  earliest: int, latest: int) -> Slot:
        """A decided slot whose start lies in [earliest, latest] when present."""
        low, high = length_bounds(signal, self.duration)
        duration = self.duration
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
        enforce = [present] if rule is True else [present, rule]
        self.cp.add(length >= low).only_enforce_if(enforce)
        self.cp.add(length <= high).only_enforce_if(enforce)
        if earliest > 0:
            self.cp.add(start >= earliest).only_enforce_if(present)
        if latest < duration:
            self.cp.add(start <= latest).only_enforce_if(present)
        self.cp.add(start == 0).only_enforce_if(~present)
        self.cp.add(stop == 0).only_enforce_if(~present)
        return Slot(signal.id, index, present, start, stop, length, group)

    def _chain(self, slots: Sequence[Slot]) -> None:
        """Ordered, non-overlapping: slot i+1 present implies slot i present and after it."""
        for previous, slot in itertools.pairwise(slots):
            self.cp.add_implication(slot.present, previous.present)
            self.cp.add(slot.start >= previous.stop).only_enforce_if(slot.present)

    def add_slots(self, counts: Mapping[str, int], step: int) -> None:
        frame = self.frame
        for signal in self.model.signals:
            count = counts.get(signal.id, 0)
            later_count = frame.later.get(signal.id, 0)
            past = [Slot(signal.id, i, True, a, b, b - a, "past")
                    for i, (a, b) in enumerate(frame.past.get(signal.id, ()))]
            bounded = signal.min_duration > 0 or signal.max_duration is not None
            rule: Lit = True
            if bounded and (count or later_count):
                upper = "inf" if signal.max_duration is None else f"{signal.max_duration:g}"
                rule = self.guard(f"duration:{signal.id}", Item(
                    signal.id, "duration", signal.span,
                    f"{signal.id} lasts between {signal.min_duration:g} and {upper} s"))
            free_from = max([frame.begin] + [int(slot.stop) for slot in past])
            # A once-only signal's one slot may start anywhere after ``begin`` (its "later"
            # option); a repetitive signal's window slots start before ``end``.
            last_window_start = self.duration if not signal.repetitive else self.end - 1
            window = [self._new_slot(signal, i, "window", step, rule, int(free_from), last_window_start)
                      for i in range(count)]
            self._chain(window)
            later = [self._new_slot(signal, count + i, "later", step, rule, max(self.end, int(free_from)),
                                    self.duration) for i in range(later_count)]
            self._chain(later)
            if later:
                for slot in window:
                    self.cp.add(later[0].start >= slot.stop).only_enforce_if([later[0].present, slot.present])
            decided = window + later
            if signal.repetitive and signal.max_occurrences is not None and decided:
                room = signal.max_occurrences - frame.committed.get(signal.id, 0)
                if room < len(decided):
                    self.cp.add(sum(slot.present for slot in decided) <= max(0, room))
            elif not signal.repetitive and len(decided) > 1:
                self.cp.add(sum(slot.present for slot in decided) <= 1)
            self.enc.slots[signal.id] = past + decided
            if past:
                self.enc.occurs[signal.id] = True
            else:
                self.enc.occurs[signal.id] = self.lor([s.present for s in (window[:1] + later[:1])])

    def add_exclusive_modalities(self) -> None:
        for modality in self.model.modalities:
            if not modality.exclusive:
                continue
            members = [slot for s in self.model.signals if s.modality == modality.name
                       for slot in self.enc.slots[s.id]
                       if slot.decided or int(slot.stop) > self.frame.begin]
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
                if not slot.decided:
                    start, length = int(slot.start), int(slot.length)
                    if rule is True:
                        intervals.append(self.cp.new_fixed_size_interval_var(start, length, ""))
                    else:
                        intervals.append(self.cp.new_optional_fixed_size_interval_var(
                            start, length, active, ""))
                    continue
                intervals.append(self.cp.new_optional_interval_var(
                    slot.start, slot.length, slot.stop, active, ""))
            self.cp.add_no_overlap(intervals)
            # The same rule once more as pairwise "one before the other" literals (shared
            # with the relational atoms) for signals that a relational atom relates:
            # NoOverlap alone cannot refute two equal-length occurrences that ``includes``
            # forces onto each other without trying every start time.  Unrelated pairs are
            # left to NoOverlap (all pairs would grow quadratically with the modality).
            related = self.related_pairs()
            for i, first in enumerate(members):
                for j in range(i + 1, len(members)):
                    second = members[j]
                    if first.signal == second.signal or (first.signal, second.signal) not in related:
                        continue
                    before = self.le(time_of_edge(first.stop), time_of_edge(second.start))
                    after = self.le(time_of_edge(second.stop), time_of_edge(first.start))
                    clause = [before, after, lnot(actives[i]), lnot(actives[j])]
                    if not any(lit is True for lit in clause):
                        self.cp.add_bool_or([lit for lit in clause if lit is not False])

    def related_pairs(self) -> frozenset[tuple[str, str]]:
        """Pairs of distinct signals named together by some relational atom (both orders)."""
        if self._related is None:
            pairs: set[tuple[str, str]] = set()
            for constraint in self.model.constraints:
                for node in ir.walk(constraint.expr):
                    if isinstance(node, ir.Relation | ir.Compare):
                        names = set(ir.atom_signals(node))
                        pairs.update((a, b) for a in names for b in names if a != b)
            self._related = frozenset(pairs)
        return self._related

    # -- terms, atoms and connectives -----------------------------------------------------
    def le(self, left: Time, right: Time, bound: int = 0) -> Lit:
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

    def time(self, term: ir.Term, chosen: Mapping[str, Slot]) -> Time:
        if isinstance(term, ir.SignalTime):
            slot = chosen[term.signal]
            return time_of_edge(slot.start if term.edge == "start" else slot.stop, term.offset)
        return Time(None, known_time(term, self.duration))

    def holds(self, atom: ir.Relation | ir.Compare, chosen: Mapping[str, Slot]) -> Lit:
        """The literal of the atom's meaning (mse.ir.relations) for one slot of each signal:
        one ``x - y <= k`` literal per bound, in the table's order, joined by and/or."""
        if isinstance(atom, ir.Relation):
            slots = {"left": chosen[atom.left], "right": chosen[atom.right]}

            def edge(end: Endpoint) -> Time:
                slot = slots[end.side]
                return time_of_edge(slot.start if end.edge == "start" else slot.stop)

            relation = RELATIONS[atom.kind]
            literals = [self.le(edge(b.lower), edge(b.upper), b.limit(0)) for b in relation.bounds]
            return self.land(literals) if relation.joined == "and" else self.lor(literals)
        terms = {"left": self.time(atom.left, chosen), "right": self.time(atom.right, chosen)}
        compare = COMPARISONS[atom.op]
        literals = [self.le(terms[b.lower], terms[b.upper], b.limit(atom.tolerance)) for b in compare.bounds]
        return self.land(literals) if compare.joined == "and" else self.lor(literals)

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
            if atom in self.frame.falsified:
                falsified.append(True)
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
                if not slot.decided:
                    choices.append((slot.start, slot.stop) == (start, stop))
                    continue
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
    violate: bool = False,
    frame: Frame | None = None,
) -> Encoding:
    """Encode ``model`` for a timeline of ``duration`` ticks with ``counts`` window slots per
    signal (and ``frame.later`` later slots; the default frame is the whole timeline).

    ``constraints=False`` leaves constraints unenforced (the paper's constraint-less mode;
    their literals still exist for lint), and ``violate`` then demands that at least one
    constraint be violated (the control condition); ``step`` > 1 restricts times to that grid."""
    builder = _Builder(model, duration, switchable, frame or Frame())
    builder.add_slots(counts, step)
    builder.add_exclusive_modalities()
    builder.add_constraints(constraints)
    builder.add_request(pins, require, forbid)
    if violate:
        violated = list(builder.enc.violated.values())
        if not any(lit is True for lit in violated):
            builder.cp.add_bool_or([lit for lit in violated if lit is not False])
    return builder.enc

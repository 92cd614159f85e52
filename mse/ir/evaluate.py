"""The one semantic evaluator (docs/semantics.md).  Every solver is tested against it.

Truth values are three-valued: ``True``, ``False`` and ``None`` (unknown).  A relational
atom is unknown when a signal it names does not occur; otherwise it holds iff its relation
holds for every assignment of one occurrence to each signal it names.  Connectives are
strong Kleene.  A constraint is *ignored* when it has trigger signals (those of its
relational atoms) and none of them occurs; otherwise it is violated iff it is false.
All times are integer milliseconds, so comparisons are exact.
"""

from __future__ import annotations

import itertools
import weakref
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

from mse.diagnostics import Span
from mse.ir import model as ir
from mse.ir.schedule import Occurrence, Schedule, to_seconds, to_ticks

Truth = bool | None
Intervals = Mapping[str, Sequence[tuple[int, int]]]


# -- atoms ------------------------------------------------------------------------------------
def _relation_holds(kind: str, a: tuple[int, int], b: tuple[int, int]) -> bool:
    if kind == "includes":
        return a[0] <= b[0] and b[1] <= a[1]
    if kind == "excludes":
        return a[1] <= b[0] or b[1] <= a[0]
    if kind == "precedes":
        return a[1] <= b[0]
    return a[0] <= b[1] <= a[1]  # rightincludes


def _term_value(term: ir.Term, chosen: Mapping[str, tuple[int, int]], duration: int) -> int:
    if isinstance(term, ir.SignalTime):
        interval = chosen[term.signal]
        return (interval[0] if term.edge == "start" else interval[1]) + term.offset
    if isinstance(term, ir.DurationTime):
        return duration + term.offset
    return term.value


def compare_holds(op: str, left: int, right: int, tolerance: int = 0) -> bool:
    if op == "<":
        return left < right
    if op == ">":
        return left > right
    if op == "<=":
        return left <= right
    if op == ">=":
        return left >= right
    return abs(left - right) <= tolerance


def evaluate_atom(atom: ir.Atom, intervals: Intervals, duration: int) -> Truth:
    if isinstance(atom, ir.Exists):
        return bool(intervals.get(atom.signal))
    names = tuple(dict.fromkeys(ir.atom_signals(atom)))
    pools = [intervals.get(name, ()) for name in names]
    if any(not pool for pool in pools):
        return None
    for combination in itertools.product(*pools):
        chosen = dict(zip(names, combination, strict=True))
        if isinstance(atom, ir.Relation):
            holds = _relation_holds(atom.kind, chosen[atom.left], chosen[atom.right])
        else:
            left = _term_value(atom.left, chosen, duration)
            right = _term_value(atom.right, chosen, duration)
            holds = compare_holds(atom.op, left, right, atom.tolerance)
        if not holds:
            return False
    return True


# -- connectives --------------------------------------------------------------------------------
def kleene_not(value: Truth) -> Truth:
    return None if value is None else not value


def kleene_and(values: Sequence[Truth]) -> Truth:
    if any(v is False for v in values):
        return False
    return None if any(v is None for v in values) else True


def kleene_or(values: Sequence[Truth]) -> Truth:
    if any(v is True for v in values):
        return True
    return None if any(v is None for v in values) else False


def evaluate_expr(expr: ir.Expr, intervals: Intervals, duration: int) -> Truth:
    if isinstance(expr, ir.Not):
        return kleene_not(evaluate_expr(expr.operand, intervals, duration))
    if isinstance(expr, ir.And):
        return kleene_and([evaluate_expr(e, intervals, duration) for e in expr.operands])
    if isinstance(expr, ir.Or):
        return kleene_or([evaluate_expr(e, intervals, duration) for e in expr.operands])
    if isinstance(expr, ir.Implies):
        left = evaluate_expr(expr.left, intervals, duration)
        return kleene_or([kleene_not(left), evaluate_expr(expr.right, intervals, duration)])
    return evaluate_atom(expr, intervals, duration)


def is_instantiated(constraint: ir.Constraint, intervals: Intervals) -> bool:
    """False when the constraint has trigger signals and none of them occurs (ignored)."""
    triggers = constraint.triggers
    return not triggers or any(intervals.get(signal) for signal in triggers)


def constraint_status(constraint: ir.Constraint, intervals: Intervals, duration: int) -> Truth:
    """True (satisfied), False (violated) or None (ignored or unknown, both fine)."""
    if not is_instantiated(constraint, intervals):
        return None
    return evaluate_expr(constraint.expr, intervals, duration)


def is_violated(constraint: ir.Constraint, intervals: Intervals, duration: int) -> bool:
    return constraint_status(constraint, intervals, duration) is False


# -- whole timelines ------------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class Violation:
    """One reason why a timeline is inconsistent with a model."""

    kind: str  # constraint | unknown-signal | bounds | duration | repetition | overlap | exclusive
    message: str
    span: Span
    constraint: str | None = None
    signals: tuple[str, ...] = ()

    def render(self) -> str:
        return f"{self.span.render()}: {self.message}"


def intervals_of(schedule: Schedule) -> dict[str, list[tuple[int, int]]]:
    grouped: dict[str, list[tuple[int, int]]] = {}
    for occurrence in schedule.occurrences:
        grouped.setdefault(occurrence.signal, []).append((occurrence.start, occurrence.stop))
    return grouped


def _where(occurrence: Occurrence) -> str:
    return f"{occurrence.signal} [{_fmt(occurrence.start)}, {_fmt(occurrence.stop)}]"


def _fmt(ticks: int) -> str:
    return f"{to_seconds(ticks):g}"


def _occurrence_violations(model: ir.Model, schedule: Schedule) -> list[Violation]:
    found: list[Violation] = []
    by_signal: dict[str, list[Occurrence]] = {}
    for occurrence in schedule.occurrences:
        signal = model.signal_by_id.get(occurrence.signal)
        if signal is None:
            found.append(
                Violation(
                    "unknown-signal",
                    f"signal {occurrence.signal!r} is not in {model.name!r}",
                    Span(model.path),
                    signals=(occurrence.signal,),
                )
            )
            continue
        by_signal.setdefault(signal.id, []).append(occurrence)
        if not 0 <= occurrence.start < occurrence.stop <= schedule.duration:
            found.append(
                Violation(
                    "bounds",
                    f"{_where(occurrence)} is outside 0 <= start < stop <= {_fmt(schedule.duration)}",
                    signal.span,
                    signals=(signal.id,),
                )
            )
        length = occurrence.stop - occurrence.start
        too_short = length < to_ticks(signal.min_duration)
        too_long = signal.max_duration is not None and length > to_ticks(signal.max_duration)
        if too_short or too_long:
            bound = f"[{signal.min_duration:g}, {'inf' if signal.max_duration is None else f'{signal.max_duration:g}'}]"
            found.append(
                Violation(
                    "duration",
                    f"{_where(occurrence)} lasts {_fmt(length)} s, outside {bound}",
                    signal.span,
                    signals=(signal.id,),
                )
            )
    for signal_id, occurrences in by_signal.items():
        signal = model.signal(signal_id)
        limit = 1 if not signal.repetitive else signal.max_occurrences
        if limit is not None and len(occurrences) > limit:
            found.append(
                Violation(
                    "repetition",
                    f"{signal_id} occurs {len(occurrences)} times; at most {limit} allowed",
                    signal.span,
                    signals=(signal_id,),
                )
            )
        ordered = sorted(occurrences)
        for first, second in itertools.pairwise(ordered):
            if second.start < first.stop:
                found.append(
                    Violation(
                        "overlap",
                        f"two occurrences of {signal_id} overlap at {_fmt(second.start)} s",
                        signal.span,
                        signals=(signal_id,),
                    )
                )
    for modality in sorted(model.exclusive_modalities):
        members = sorted(
            o
            for o in schedule.occurrences
            if o.signal in model.signal_by_id and model.signal(o.signal).modality == modality
        )
        for index, first in enumerate(members):
            for second in members[index + 1 :]:
                if second.start >= first.stop:
                    break
                if first.signal != second.signal:
                    found.append(
                        Violation(
                            "exclusive",
                            f"{first.signal} and {second.signal} overlap in exclusive modality {modality!r}",
                            model.signal(second.signal).span,
                            signals=(first.signal, second.signal),
                        )
                    )
    return found


def check_schedule(model: ir.Model, schedule: Schedule) -> list[Violation]:
    """Every violation of ``schedule`` against ``model`` (empty: consistent).

    A consistent schedule is recognised by a checker compiled once per model (:func:`is_clean`)
    without building any message; anything else goes through the full path below, so the
    result is the same list either way."""
    if is_clean(model, schedule):
        return []
    return _all_violations(model, schedule)


def _all_violations(model: ir.Model, schedule: Schedule) -> list[Violation]:
    found = _occurrence_violations(model, schedule)
    intervals = intervals_of(schedule)
    for constraint in model.constraints:
        if is_violated(constraint, intervals, schedule.duration):
            text = constraint.text or constraint.id
            found.append(
                Violation(
                    "constraint",
                    f"constraint {constraint.id!r} violated: {text}",
                    constraint.span,
                    constraint=constraint.id,
                    signals=tuple(sorted(ir.mentioned_signals(constraint.expr))),
                )
            )
    return found


def is_consistent(model: ir.Model, schedule: Schedule) -> bool:
    return not check_schedule(model, schedule)


# -- the fast path: recognising a consistent schedule without building messages ---------------
# The sampler verifies every timeline it returns; almost all of them are consistent, so the
# common answer "no violation" is computed by closures compiled once per model.  They decide
# exactly what the functions above decide (tests/test_greedy_check.py compares them); any
# doubt -- an unknown signal, any structural or constraint violation -- sends the schedule
# through the full path, which builds the messages.
_Pool = Sequence[tuple[int, int]]
_Node = Callable[[Mapping[str, _Pool], int], Truth]

_RELATIONS: dict[str, Callable[[tuple[int, int], tuple[int, int]], bool]] = {
    "includes": lambda a, b: a[0] <= b[0] and b[1] <= a[1],
    "excludes": lambda a, b: a[1] <= b[0] or b[1] <= a[0],
    "precedes": lambda a, b: a[1] <= b[0],
    "rightincludes": lambda a, b: a[0] <= b[1] <= a[1],
}


def _compile_relation(atom: ir.Relation) -> _Node:
    holds, left, right = _RELATIONS[atom.kind], atom.left, atom.right
    if left == right:  # one occurrence stands for both names

        def same(intervals: Mapping[str, _Pool], _duration: int) -> Truth:
            pool = intervals.get(left)
            return None if not pool else all(holds(a, a) for a in pool)

        return same

    def pair(intervals: Mapping[str, _Pool], _duration: int) -> Truth:
        lefts, rights = intervals.get(left), intervals.get(right)
        if not lefts or not rights:
            return None
        for a in lefts:
            for b in rights:
                if not holds(a, b):
                    return False
        return True

    return pair


def _reader(term: ir.Term) -> Callable[[tuple[int, int], int], int]:
    """The value of ``term`` given the chosen interval of its signal and the duration."""
    if isinstance(term, ir.SignalTime):
        index, offset = (0 if term.edge == "start" else 1), term.offset
        return lambda interval, _duration: interval[index] + offset
    if isinstance(term, ir.DurationTime):
        after = term.offset
        return lambda _interval, duration: duration + after
    value = term.value
    return lambda _interval, _duration: value


def _compile_compare(atom: ir.Compare) -> _Node:
    names = tuple(dict.fromkeys(ir.atom_signals(atom)))  # the left term's signal first
    if not names:
        return lambda intervals, duration: evaluate_atom(atom, intervals, duration)
    op, tolerance, left, right = atom.op, atom.tolerance, _reader(atom.left), _reader(atom.right)
    if len(names) == 1:  # a signal against a constant, or against itself
        name = names[0]

        def one(intervals: Mapping[str, _Pool], duration: int) -> Truth:
            pool = intervals.get(name)
            if not pool:
                return None
            return all(compare_holds(op, left(a, duration), right(a, duration), tolerance) for a in pool)

        return one
    a_name, b_name = names

    def two(intervals: Mapping[str, _Pool], duration: int) -> Truth:
        lefts, rights = intervals.get(a_name), intervals.get(b_name)
        if not lefts or not rights:
            return None
        for a in lefts:
            value = left(a, duration)
            for b in rights:
                if not compare_holds(op, value, right(b, duration), tolerance):
                    return False
        return True

    return two


def _compile(expr: ir.Expr) -> _Node:
    """A closure equal to ``evaluate_expr(expr, ...)``."""
    if isinstance(expr, ir.Exists):
        name = expr.signal
        return lambda intervals, _duration: bool(intervals.get(name))
    if isinstance(expr, ir.Relation):
        return _compile_relation(expr)
    if isinstance(expr, ir.Compare):
        return _compile_compare(expr)
    if isinstance(expr, ir.Not):
        inner = _compile(expr.operand)
        return lambda intervals, duration: kleene_not(inner(intervals, duration))
    if isinstance(expr, ir.Implies):
        premise, conclusion = _compile(expr.left), _compile(expr.right)
        return lambda intervals, duration: kleene_or(
            [kleene_not(premise(intervals, duration)), conclusion(intervals, duration)]
        )
    parts = [_compile(e) for e in ir.children(expr)]
    combine = kleene_and if isinstance(expr, ir.And) else kleene_or
    return lambda intervals, duration: combine([part(intervals, duration) for part in parts])


_NO_LIMIT = 1 << 62  # stands for "unbounded": no length or count reaches it


class _Checker:
    """One model, compiled: :meth:`clean` is True iff :func:`check_schedule` finds nothing."""

    __slots__ = ("constraints", "limits")

    def __init__(self, model: ir.Model) -> None:
        exclusive = model.exclusive_modalities
        #: signal -> (shortest, longest, most occurrences, exclusive modality or None), in ticks
        self.limits: dict[str, tuple[int, int, int, str | None]] = {
            s.id: (
                to_ticks(s.min_duration),
                _NO_LIMIT if s.max_duration is None else to_ticks(s.max_duration),
                1 if not s.repetitive else _NO_LIMIT if s.max_occurrences is None else s.max_occurrences,
                s.modality if s.modality in exclusive else None,
            )
            for s in model.signals
        }
        self.constraints = tuple((tuple(c.triggers), _compile(c.expr)) for c in model.constraints)

    def clean(self, schedule: Schedule) -> bool:
        duration, limits = schedule.duration, self.limits
        grouped: dict[str, list[tuple[int, int]]] = {}
        for occurrence in schedule.occurrences:
            name, start, stop = occurrence.signal, occurrence.start, occurrence.stop
            spec = limits.get(name)
            if spec is None or not 0 <= start < stop <= duration:
                return False
            if not spec[0] <= stop - start <= spec[1]:
                return False
            pool = grouped.get(name)
            if pool is None:
                grouped[name] = [(start, stop)]
            else:
                pool.append((start, stop))
        by_modality: dict[str, list[tuple[int, int]]] = {}
        for name, pool in grouped.items():
            _, _, most, modality = limits[name]
            if len(pool) > 1:
                if len(pool) > most:
                    return False
                ordered = sorted(pool)
                for first, second in itertools.pairwise(ordered):
                    if second[0] < first[1]:
                        return False
            elif most < 1:
                return False
            if modality is not None:
                members = by_modality.get(modality)
                if members is None:
                    by_modality[modality] = pool
                else:
                    by_modality[modality] = members + pool  # a new list: pools stay as they are
        for members in by_modality.values():
            # No two occurrences of one signal overlap (checked above), so any overlap in the
            # modality is between two signals: an exclusivity violation.
            if len(members) > 1:
                reach = -1
                for start, stop in sorted(members):
                    if start < reach:
                        return False
                    if stop > reach:
                        reach = stop
        for triggers, node in self.constraints:
            if triggers:
                for name in triggers:
                    if name in grouped:  # grouped holds no empty list
                        break
                else:
                    continue  # ignored: no trigger occurs
            if node(grouped, duration) is False:
                return False
        return True


# Compiled per model object (identity: hashing a whole model per call would cost more than the
# check); the weak reference tells a reused id from the same model.
_CHECKERS: dict[int, tuple[weakref.ref[ir.Model], _Checker]] = {}
_CHECKERS_LIMIT = 256


def is_clean(model: ir.Model, schedule: Schedule) -> bool:
    """True iff :func:`check_schedule` would return no violation (fast: no messages)."""
    entry = _CHECKERS.get(id(model))
    if entry is None or entry[0]() is not model:
        if len(_CHECKERS) >= _CHECKERS_LIMIT:
            _CHECKERS.clear()
        entry = _CHECKERS[id(model)] = (weakref.ref(model), _Checker(model))
    return entry[1].clean(schedule)

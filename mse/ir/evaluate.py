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
from collections.abc import Mapping, Sequence
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
    """Every violation of ``schedule`` against ``model`` (empty: consistent)."""
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

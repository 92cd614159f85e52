"""The one semantic evaluator (docs/semantics.md).  Every solver is tested against it.

Truth values are three-valued: ``True``, ``False`` and ``None`` (unknown).  A relational
atom is unknown when a signal it names does not occur; otherwise it holds iff its relation
holds for every assignment of one occurrence to each signal it names.  Connectives are
strong Kleene.  A constraint is *ignored* when it has trigger signals (those of its
relational atoms) and none of them occurs; otherwise it is violated iff it is false.
All times are integer milliseconds, so comparisons are exact.  What each relation and
comparison means is the one table of :mod:`mse.ir.relations`.

The package's parts: :mod:`.semantics` (the law: truth values, atoms, connectives, constraints),
this module (whole timelines: their violations, with messages) and :mod:`.fast` (recognising a
consistent timeline without building messages, checked equal to the full path).  Import from
here: ``mse.ir.evaluate`` is the one entry point.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

from mse.diagnostics import Span
from mse.ir import model as ir
from mse.ir.evaluate.fast import _compile as _compile
from mse.ir.evaluate.fast import constraints_hold, is_clean
from mse.ir.evaluate.semantics import (
    Intervals,
    Truth,
    compare_holds,
    constraint_status,
    evaluate_atom,
    evaluate_expr,
    is_instantiated,
    is_violated,
    kleene_and,
    kleene_not,
    kleene_or,
)
from mse.ir.schedule import Occurrence, Schedule, to_seconds, to_ticks

__all__ = [
    "Intervals", "Truth", "Violation", "check_schedule", "compare_holds", "constraint_status", "constraints_hold",
    "evaluate_atom",
    "evaluate_expr", "intervals_of", "is_clean", "is_consistent", "is_instantiated", "is_violated", "kleene_and",
    "kleene_not", "kleene_or",
]


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
    """True iff :func:`check_schedule` finds no violation, stopping at the first one (the
    compiled checker, :func:`is_clean`): what rejection sampling asks of every draw, most of
    which are rejected."""
    return is_clean(model, schedule)



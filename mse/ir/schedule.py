"""A schedule: the solver-level view of a timeline, on the 1 ms grid.

All times are integers in milliseconds so that equalities and offsets are exact.
``mse.timeline.Timeline`` is the user-facing form (seconds, metadata, JSON).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

TICKS_PER_SECOND = 1000


def to_ticks(seconds: float) -> int:
    """Seconds to the nearest millisecond tick."""
    return round(seconds * TICKS_PER_SECOND)


def to_seconds(ticks: int) -> float:
    return ticks / TICKS_PER_SECOND


@dataclass(frozen=True, slots=True, order=True)
class Occurrence:
    """One occurrence of a signal: [start, stop) in milliseconds."""

    start: int
    stop: int
    signal: str


@dataclass(frozen=True, slots=True)
class Schedule:
    """The occurrences of a timeline of ``duration`` milliseconds."""

    duration: int
    occurrences: tuple[Occurrence, ...]

    @staticmethod
    def of(duration: int, occurrences: Iterable[Occurrence]) -> Schedule:
        return Schedule(duration, tuple(sorted(occurrences, key=lambda o: (o.start, o.signal, o.stop))))

    def by_signal(self) -> Mapping[str, list[Occurrence]]:
        grouped: dict[str, list[Occurrence]] = {}
        for occurrence in self.occurrences:
            grouped.setdefault(occurrence.signal, []).append(occurrence)
        return grouped

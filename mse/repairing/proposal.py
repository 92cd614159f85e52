"""A proposed expression, as read from any of its three forms (docs/repair.md).

Whatever the form (a timeline, a light proposal, tagged text), a proposal becomes the same
thing: occurrences on the 1 ms grid, each resolved to a signal of the set or marked
*foreign* (the set does not know its name), with where it was written.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

from mse.diagnostics import Span
from mse.ir import model as ir
from mse.ir.schedule import Occurrence, Schedule, to_ticks

if TYPE_CHECKING:
    from mse.timeline import Timeline

Form = Literal["timeline", "proposal", "text"]

#: The most occurrences one proposal may hold (each becomes variables of one CP-SAT model).
MAX_PROPOSED = 1000
#: Weights of moving one occurrence (cost of a millisecond moved): integers in this range.
MAX_WEIGHT = 1000


@dataclass(frozen=True, slots=True)
class ProposedOccurrence:
    """One proposed occurrence.  ``signal`` is the set's signal id, None when the set does not
    know ``name`` (a foreign occurrence: reported, kept out of the solve).  Times are ticks;
    ``estimated`` says they were derived (order and rough length, or a speaking rate)."""

    name: str
    signal: str | None
    start: int
    stop: int
    weight: int = 1
    keep: bool = False
    fixed: bool = False
    label: str | None = None
    estimated: bool = False
    span: Span = ir.NO_SPAN

    def describe(self) -> str:
        """``smile [1.2, 3] s`` (and its label when it has one)."""
        label = f" {self.label!r}" if self.label else ""
        return f"{self.name}{label} [{self.start / 1000:g}, {self.stop / 1000:g}] s"


@dataclass(frozen=True)
class Proposal:
    """The occurrences a proposal holds and the duration of the timeline it proposes (ticks).

    ``timeline`` is the timeline as read when the proposal came in that form (a consistent one
    is returned as it is); ``text`` is the document as read (the command line writes it back
    unchanged when nothing changes)."""

    duration: int
    occurrences: tuple[ProposedOccurrence, ...]
    form: Form = "proposal"
    path: str = "<proposal>"
    expression: str = ""
    timeline: Timeline | None = None
    text: str | None = None

    @property
    def known(self) -> tuple[ProposedOccurrence, ...]:
        return tuple(o for o in self.occurrences if o.signal is not None)

    @property
    def foreign(self) -> tuple[ProposedOccurrence, ...]:
        return tuple(o for o in self.occurrences if o.signal is None)

    def schedule(self) -> Schedule:
        """The known occurrences as a schedule (what the evaluator checks)."""
        return Schedule.of(self.duration, (Occurrence(o.start, o.stop, o.signal) for o in self.known
                                           if o.signal is not None))


def typical_length(signal: ir.Signal) -> int:
    """The length (ticks) given to an occurrence proposed without one: the middle of the
    signal's duration bounds, or its ``min_duration`` (at least 1 s) when it has no maximum."""
    low = to_ticks(signal.min_duration)
    if signal.max_duration is None:
        return max(low, 1000)
    return max(1, (low + to_ticks(signal.max_duration)) // 2)

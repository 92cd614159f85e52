"""Episodes of a dialogue: the one meaning of a multi-episode timeline (docs/semantics.md,
"Episodes").  Each episode is checked alone, against its own behaviour set:

- an episode that ran as planned (its announced end reached, or a horizon completed) is an
  expression of exactly its length: every rule holds as for one timeline;
- an *interrupted* episode is the prefix of a plan: the plan (the played occurrences, the cut
  ones with their planned stop, and the dropped ones) must be an expression of the plan's length,
  and the played part must be that plan cut at the interruption: occurrences that started before
  it are kept, those open at it are *cut* (they stop at most :data:`mse.envelope.CUT_RELEASE`
  after it, never after their planned stop), those after it are dropped.  A cut occurrence is
  exempt, in what was played, from every rule about its stop (its duration bounds and each
  constraint that sees it); an interrupted episode is exempt from what only its unplayed
  remainder would have done (its plan, not its prefix, is checked);
- episodes follow each other without gap or overlap from 0 to the dialogue's end, so a face
  without signals between episodes happens only where a set's own expression allows it.

Times are ticks (ms) as everywhere in the evaluator.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from mse.diagnostics import Span
from mse.ir import model as ir
from mse.ir.evaluate import Violation, check_schedule
from mse.ir.schedule import Occurrence, Schedule, to_seconds

#: The longest release of a cut occurrence, in ticks (mse.envelope.CUT_RELEASE; the evaluator
#: sits below it, and tests keep the two equal).
CUT_RELEASE_TICKS = 200


@dataclass(frozen=True)
class Episode:
    """One episode: absolute times in ticks; ``cut`` pairs each cut occurrence (as played) with
    its planned stop; ``dropped`` are planned occurrences that never started."""

    index: int
    emotion: str
    model: ir.Model
    start: int
    stop: int
    plan_stop: int
    played: tuple[Occurrence, ...]
    cut: tuple[tuple[Occurrence, int], ...] = ()
    dropped: tuple[Occurrence, ...] = ()
    interrupted: bool = False

    def plan(self) -> Schedule:
        """The plan the episode played (all of it when not interrupted), from 0."""
        planned = [*self.played, *(Occurrence(o.start, stop, o.signal) for o, stop in self.cut), *self.dropped]
        return Schedule.of(self.plan_stop - self.start,
                           (Occurrence(o.start - self.start, o.stop - self.start, o.signal) for o in planned))


@dataclass(frozen=True, slots=True)
class EpisodeViolation:
    """A violation inside one episode (``episode`` is its index)."""

    episode: int
    emotion: str
    violation: Violation

    def render(self) -> str:
        return f"{self.violation.span.render()}: [episode {self.episode} ({self.emotion})] {self.violation.message}"


def _s(ticks: int) -> str:
    return f"{to_seconds(ticks):g}"


def _cut_problems(episode: Episode) -> list[str]:
    """How the played part differs from the plan cut at the episode's stop."""
    problems: list[str] = []
    end = episode.stop
    for o in episode.played:
        if not episode.start <= o.start < end or o.stop > end:
            problems.append(f"{o.signal} [{_s(o.start)}, {_s(o.stop)}] lies outside the episode "
                            f"[{_s(episode.start)}, {_s(end)}] and is not cut")
    for o, planned in episode.cut:
        if not (episode.interrupted and episode.start <= o.start < end < planned):
            problems.append(f"{o.signal} [{_s(o.start)}, {_s(planned)}] is marked cut but was not open at the "
                            f"interruption at {_s(end)} s")
        elif not end <= o.stop <= min(planned, end + CUT_RELEASE_TICKS):
            problems.append(f"{o.signal} cut at {_s(end)} s stops at {_s(o.stop)} s: a cut occurrence releases "
                            f"within {_s(CUT_RELEASE_TICKS)} s of the cut, never after its planned stop")
    for o in episode.dropped:
        if not episode.interrupted or o.start < end or o.stop > episode.plan_stop:
            problems.append(f"{o.signal} [{_s(o.start)}, {_s(o.stop)}] is marked dropped but starts before the "
                            f"interruption at {_s(end)} s")
    if episode.plan_stop < end or (not episode.interrupted and episode.plan_stop != end):
        problems.append(f"the plan ends at {_s(episode.plan_stop)} s, the episode at {_s(end)} s")
    return problems


def check_episode(episode: Episode) -> list[Violation]:
    """Every violation of one episode (empty: consistent with its set)."""
    span = Span(episode.model.path)
    found = [Violation("episode", problem, span) for problem in _cut_problems(episode)]
    if episode.plan_stop <= episode.start:
        return [*found, Violation("episode", "the episode has no length", span)]
    return [*found, *check_schedule(episode.model, episode.plan())]


def check_episodes(episodes: Sequence[Episode], duration: int) -> list[EpisodeViolation]:
    """Every violation of a dialogue, episode by episode, then the gaps and overlaps between them."""
    found: list[EpisodeViolation] = []
    at = 0
    for episode in sorted(episodes, key=lambda e: (e.start, e.index)):
        span = Span(episode.model.path)
        if episode.start != at:
            what = "gap" if episode.start > at else "overlap"
            message = (f"{what} between episodes: the previous one ends at {_s(at)} s, this one starts at "
                       f"{_s(episode.start)} s (episodes follow each other without gap or overlap)")
            found.append(EpisodeViolation(episode.index, episode.emotion, Violation("episode", message, span)))
        found.extend(EpisodeViolation(episode.index, episode.emotion, v) for v in check_episode(episode))
        at = episode.stop
    if episodes and at != duration:
        last = max(episodes, key=lambda e: e.stop)
        message = f"the episodes end at {_s(at)} s, the dialogue at {_s(duration)} s"
        found.append(EpisodeViolation(last.index, last.emotion, Violation("episode", message, Span(last.model.path))))
    return found

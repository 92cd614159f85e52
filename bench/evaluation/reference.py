"""The reference sampler: the target distribution of every sampler, drawn exactly.

docs/semantics.md ("Probabilities") names the target: the *prior* (each signal on its own,
mse/ir/profile.py) conditioned on the timeline being consistent.  :func:`prior_timeline`
draws one timeline from the prior; keeping the draws that :func:`check_schedule` (the one
evaluator) accepts is rejection sampling from the target (:func:`sample_reference`).  It is
exact and slow: it only works where enough draws are consistent, which is what the
``acceptance`` it reports says.  Benches (``bench.evaluation.distribution``,
``bench.speed.sample --fidelity``) and tests (tests/test_distribution.py) use it.

The prior, as drawn here (profile.py's words, made precise where a start cannot fit):

* a **once-only** signal occurs with probability ``(probability_start + probability_end) / 2``;
  its start has density proportional to ``p(u)`` over the starts where its ``min_duration``
  fits (``[0, D - min_duration]``);
* a **repetitive** signal, while free (not running, below ``max_occurrences``, and where its
  ``min_duration`` still fits), starts with probability ``p(u)`` within each second: a
  Poisson process of intensity ``-ln(1 - p(u))`` per second, drawn exactly by thinning;
* lengths are triangular on ``[min_duration, max]``, the mode in the middle, ``max`` being
  ``max_duration`` capped by the end of the timeline.

:func:`statistics` gives what the bench table compares: the mean number of once-only signals
per timeline and, per signal, its *rate*: for a once-only signal the fraction of timelines
where it occurs, for a repetitive one its occurrences per 10 s of timeline (so that rates of
different durations compare).  :func:`prior_statistics` is the same for the prior alone, in
closed form where profile.py gives one (tests check the sampler against it).
"""

from __future__ import annotations

import math
import random
import time
from collections.abc import Sequence
from dataclasses import dataclass

from mse.ir import model as ir
from mse.ir.evaluate import check_schedule
from mse.ir.profile import mean_relative_start, occurrence_probability, profile_at
from mse.ir.schedule import TICKS_PER_SECOND, Occurrence, Schedule, to_ticks

#: Repetitive rates are counted per this many seconds of timeline.
RATE_SECONDS = 10.0


def _shortest(signal: ir.Signal) -> int:
    return max(1, to_ticks(signal.min_duration))


def _length(rng: random.Random, signal: ir.Signal, start: int, duration: int) -> int:
    low = _shortest(signal)
    high = duration - start if signal.max_duration is None else min(duration - start, to_ticks(signal.max_duration))
    if high <= low:
        return low
    return round(rng.triangular(low, high, (low + high) / 2))


def _linear_draw(rng: random.Random, start: float, end: float) -> float:
    """v in [0, 1] with density proportional to start + (end - start) v."""
    if abs(end - start) < 1e-12 * max(1.0, abs(start)):
        return rng.random()
    area = (start + end) / 2
    target = rng.random() * area
    a, b = (end - start) / 2, start
    return (-b + math.sqrt(max(0.0, b * b + 4 * a * target))) / (2 * a)


def _intensity(p: float) -> float:
    """Starts per second of a free repetitive signal that starts with probability p within a second."""
    return -math.log1p(-min(p, 1.0 - 1e-9)) if p > 0 else 0.0


def draw_once(signal: ir.Signal, duration: int, rng: random.Random) -> Occurrence | None:
    """A once-only signal drawn from the prior (None: absent)."""
    last = duration - _shortest(signal)
    if last < 0 or rng.random() >= occurrence_probability(signal):
        return None
    reach = last / duration
    v = _linear_draw(rng, profile_at(signal, 0.0), profile_at(signal, reach))
    start = min(last, int(v * reach * duration))
    return Occurrence(start, start + _length(rng, signal, start, duration), signal.id)


def draw_repetitive(signal: ir.Signal, duration: int, rng: random.Random) -> list[Occurrence]:
    """A repetitive signal's occurrences drawn from the prior (thinning of its Poisson process)."""
    last = duration - _shortest(signal)
    peak = max(_intensity(signal.probability_start), _intensity(signal.probability_end))
    found: list[Occurrence] = []
    if peak <= 0 or last < 0:
        return found
    limit = signal.max_occurrences
    t = 0.0  # seconds
    while limit is None or len(found) < limit:
        t += rng.expovariate(peak)
        start = math.ceil(t * TICKS_PER_SECOND)
        if start > last:
            break
        if rng.random() * peak > _intensity(profile_at(signal, start / duration)):
            continue
        stop = start + _length(rng, signal, start, duration)
        found.append(Occurrence(start, stop, signal.id))
        t = stop / TICKS_PER_SECOND
    return found


def prior_timeline(model: ir.Model, duration: int, rng: random.Random) -> Schedule:
    """One draw of the prior: every signal on its own (``duration`` in ticks)."""
    occurrences: list[Occurrence] = []
    for signal in model.signals:
        if signal.repetitive:
            occurrences.extend(draw_repetitive(signal, duration, rng))
        else:
            drawn = draw_once(signal, duration, rng)
            if drawn is not None:
                occurrences.append(drawn)
    return Schedule.of(duration, occurrences)


@dataclass(frozen=True)
class Reference:
    """Consistent draws of the prior (``accepted``) out of ``draws``."""

    accepted: tuple[Schedule, ...]
    draws: int

    @property
    def acceptance(self) -> float:
        return len(self.accepted) / self.draws if self.draws else 0.0


def sample_reference(model: ir.Model, duration: float, *, wanted: int, seed: int, max_draws: int,
                     max_seconds: float | None = None) -> Reference:
    """Rejection sampling of the target: prior draws until ``wanted`` are consistent, at most
    ``max_draws`` draws (and ``max_seconds`` of wall time).  Draw i uses the stream of one
    ``random.Random(seed)``, so a seed fixes the result."""
    rng = random.Random(seed)
    ticks = to_ticks(duration)
    accepted: list[Schedule] = []
    draws = 0
    began = time.monotonic()
    while draws < max_draws and len(accepted) < wanted:
        if max_seconds is not None and draws % 64 == 0 and time.monotonic() - began > max_seconds:
            break
        draws += 1
        schedule = prior_timeline(model, ticks, rng)
        if not check_schedule(model, schedule):
            accepted.append(schedule)
    return Reference(tuple(accepted), draws)


@dataclass(frozen=True)
class Statistics:
    """What the distribution bench compares (see the module's docstring)."""

    once_per_timeline: float
    rate: dict[str, float]
    start: dict[str, float | None]  # mean start (s) of the signal's occurrences
    count: int


def statistics(model: ir.Model, schedules: Sequence[Schedule], duration: float) -> Statistics:
    counts = {s.id: 0 for s in model.signals}
    starts: dict[str, list[int]] = {s.id: [] for s in model.signals}
    once = 0
    repetitive = {s.id for s in model.signals if s.repetitive}
    for schedule in schedules:
        seen: set[str] = set()
        for occurrence in schedule.occurrences:
            name = occurrence.signal
            starts[name].append(occurrence.start)
            if name in repetitive:
                counts[name] += 1
            elif name not in seen:
                counts[name] += 1
                once += 1
            seen.add(name)
    total = max(1, len(schedules))
    scale = {s.id: (RATE_SECONDS / duration if s.repetitive else 1.0) for s in model.signals}
    return Statistics(
        once / total,
        {k: v / total * scale[k] for k, v in counts.items()},
        {k: (sum(v) / len(v) / TICKS_PER_SECOND if v else None) for k, v in starts.items()},
        len(schedules),
    )


def prior_statistics(model: ir.Model, duration: float) -> Statistics:
    """The prior's own statistics in closed form: once-only signals' rates and mean starts
    (profile.py; the mean start over the whole span, exact when ``min_duration`` is small
    against the duration); repetitive signals: NaN (no closed form with lengths)."""
    rate: dict[str, float] = {}
    start: dict[str, float | None] = {}
    for signal in model.signals:
        if signal.repetitive:
            rate[signal.id], start[signal.id] = float("nan"), None
        else:
            rate[signal.id] = occurrence_probability(signal)
            start[signal.id] = mean_relative_start(signal) * duration
    once = sum(v for s, v in rate.items() if not model.signal(s).repetitive)
    return Statistics(once, rate, start, 0)

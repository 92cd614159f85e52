"""How closely sampled timelines follow the probability definition (mse/ir/profile.py).

The target of a sampler is the *prior* (each signal on its own, as profile.py defines it)
conditioned on consistency.  :func:`prior_timeline` draws from the prior; keeping the
consistent draws (``check_schedule``) is rejection sampling from the target.  When too few
draws are consistent, the table falls back to the unconstrained prediction (the prior's own
marginals), and says so.

Per signal the table compares the occurrence rate (once-only signals: the fraction of
timelines where it occurs; repetitive ones: occurrences per timeline) and the mean start
(seconds) of the target with each solver's.
"""

from __future__ import annotations

import math
import random
from collections.abc import Sequence
from dataclasses import dataclass

from mse.ir import model as ir
from mse.ir.evaluate import check_schedule
from mse.ir.profile import RATE_UNIT, mean_relative_start, occurrence_probability
from mse.ir.schedule import Occurrence, Schedule, to_ticks

#: Step (ms) of the simulation of repetitive signals' starts.
STEP = 10


def _linear_draw(rng: random.Random, start: float, end: float) -> float:
    """u in [0, 1] with density proportional to start + (end - start) u."""
    if abs(end - start) < 1e-12:
        return rng.random()
    # inverse of the CDF (start u + (end - start) u^2 / 2) / ((start + end) / 2)
    area = (start + end) / 2
    target = rng.random() * area
    a, b = (end - start) / 2, start
    return (-b + math.sqrt(b * b + 4 * a * target)) / (2 * a)


def _length(rng: random.Random, signal: ir.Signal, start: int, duration: int) -> int | None:
    low = to_ticks(signal.min_duration)
    high = duration - start if signal.max_duration is None else min(duration - start, to_ticks(signal.max_duration))
    if low > high:
        return None
    return round(rng.triangular(low, high, (low + high) / 2))


def prior_timeline(model: ir.Model, duration: int, rng: random.Random) -> Schedule | None:
    """One draw of the prior (None: a drawn occurrence does not fit in the timeline)."""
    occurrences: list[Occurrence] = []
    for signal in model.signals:
        a, b = signal.probability_start, signal.probability_end
        if not signal.repetitive:
            if rng.random() >= occurrence_probability(signal):
                continue
            start = min(duration - 1, int(_linear_draw(rng, a, b) * duration))
            length = _length(rng, signal, start, duration)
            if length is None or length < 1:
                return None
            occurrences.append(Occurrence(start, start + length, signal.id))
            continue
        t, count = 0, 0
        limit = signal.max_occurrences
        while t < duration and (limit is None or count < limit):
            p = a + (b - a) * t / duration
            if p > 0 and rng.random() < 1 - (1 - min(p, 1.0)) ** (STEP / (RATE_UNIT * 1000)):
                length = _length(rng, signal, t, duration)
                if length is None or length < 1:
                    return None
                occurrences.append(Occurrence(t, t + length, signal.id))
                count += 1
                t += length
            else:
                t += STEP
    return Schedule.of(duration, occurrences)


@dataclass
class Marginals:
    """Per signal: occurrence rate and mean start (seconds); ``count`` timelines."""

    rate: dict[str, float]
    start: dict[str, float | None]
    count: int


def marginals(model: ir.Model, schedules: Sequence[Schedule]) -> Marginals:
    counts = {s.id: 0 for s in model.signals}
    starts: dict[str, list[int]] = {s.id: [] for s in model.signals}
    for schedule in schedules:
        seen: set[str] = set()
        for occurrence in schedule.occurrences:
            signal = model.signal(occurrence.signal)
            if signal.repetitive or occurrence.signal not in seen:
                counts[occurrence.signal] += 1
            seen.add(occurrence.signal)
            starts[occurrence.signal].append(occurrence.start)
    total = max(1, len(schedules))
    return Marginals(
        {k: v / total for k, v in counts.items()},
        {k: (sum(v) / len(v) / 1000 if v else None) for k, v in starts.items()},
        len(schedules),
    )


def unconstrained(model: ir.Model, duration: float) -> Marginals:
    """The prior's marginals of once-only signals (repetitive ones: not predicted, None)."""
    rate: dict[str, float] = {}
    start: dict[str, float | None] = {}
    for signal in model.signals:
        if signal.repetitive:
            rate[signal.id], start[signal.id] = float("nan"), None
        else:
            rate[signal.id] = occurrence_probability(signal)
            start[signal.id] = mean_relative_start(signal) * duration
    return Marginals(rate, start, 0)


def target(model: ir.Model, duration: float, draws: int, seed: int, minimum: int) -> tuple[Marginals, str, float]:
    """The target marginals, how they were obtained and the acceptance rate: rejection
    sampling from the prior when at least ``minimum`` of ``draws`` draws are consistent, else
    the unconstrained prediction."""
    rng = random.Random(seed)
    ticks = to_ticks(duration)
    accepted: list[Schedule] = []
    for _ in range(draws):
        schedule = prior_timeline(model, ticks, rng)
        if schedule is not None and not check_schedule(model, schedule):
            accepted.append(schedule)
    rate = len(accepted) / draws
    if len(accepted) >= minimum:
        return marginals(model, accepted), "rejection", rate
    return unconstrained(model, duration), "prior", rate

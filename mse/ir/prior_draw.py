"""One timeline drawn from the *prior* (:mod:`mse.ir.profile`): every signal on its own, before
any constraint.  This is the prior's definition made executable; keeping only the draws the one
evaluator accepts is exact sampling of the target distribution (the prior conditioned on
consistency, docs/semantics.md "Probabilities"): the rejection stage of the samplers
(:mod:`mse.solve.rejection`) and the reference sampler of the benches
(bench/evaluation/reference.py) both draw with :func:`prior_timeline`.

The prior, as drawn here (profile.py's words, made precise where a start cannot fit):

* a **once-only** signal occurs with probability ``(probability_start + probability_end) / 2``;
  its start has density proportional to ``p(u)`` over the starts where its ``min_duration``
  fits (``[0, D - min_duration]``);
* a **repetitive** signal, while free (not running, below ``max_occurrences``, and where its
  ``min_duration`` still fits), starts with probability ``p(u)`` within each second: a
  Poisson process of intensity :func:`mse.ir.profile.start_rate`, drawn exactly by thinning;
* lengths are triangular on ``[min_duration, max]``, the mode in the middle, ``max`` being
  ``max_duration`` capped by the end of the timeline.
"""

from __future__ import annotations

import math
import random
from collections.abc import Collection

from mse.ir import model as ir
from mse.ir.profile import occurrence_probability, profile_at, start_rate
from mse.ir.schedule import TICKS_PER_SECOND, Occurrence, Schedule, to_ticks


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
    found: list[Occurrence] = []
    if last < 0 or (signal.probability_start <= 0 and signal.probability_end <= 0):
        return found
    peak = max(start_rate(signal, 0.0), start_rate(signal, 1.0))
    limit = signal.max_occurrences
    t = 0.0  # seconds
    while limit is None or len(found) < limit:
        t += rng.expovariate(peak)
        start = math.ceil(t * TICKS_PER_SECOND)
        if start > last:
            break
        if rng.random() * peak > start_rate(signal, start / duration):
            continue
        stop = start + _length(rng, signal, start, duration)
        found.append(Occurrence(start, stop, signal.id))
        t = stop / TICKS_PER_SECOND
    return found


def prior_timeline(model: ir.Model, duration: int, rng: random.Random,
                   absent: Collection[str] = ()) -> Schedule:
    """One draw of the prior: every signal on its own (``duration`` in ticks).  Signals in
    ``absent`` are not drawn: the prior conditioned on their absence (signals are independent
    under the prior, so the others are drawn as they are)."""
    occurrences: list[Occurrence] = []
    for signal in model.signals:
        if signal.id in absent:
            continue
        if signal.repetitive:
            occurrences.extend(draw_repetitive(signal, duration, rng))
        else:
            drawn = draw_once(signal, duration, rng)
            if drawn is not None:
                occurrences.append(drawn)
    return Schedule.of(duration, occurrences)

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


def _longest(signal: ir.Signal) -> int | None:
    return None if signal.max_duration is None else to_ticks(signal.max_duration)


class _Once:
    """A once-only signal's draw on one duration, its constants computed once."""

    __slots__ = ("duration", "last", "linear", "longest", "name", "occurs", "shortest", "slope", "start")

    def __init__(self, signal: ir.Signal, duration: int) -> None:
        self.name, self.duration = signal.id, duration
        self.shortest, self.longest = _shortest(signal), _longest(signal)
        self.last = duration - self.shortest
        self.occurs = occurrence_probability(signal) if self.last >= 0 else 0.0
        # The start's density is proportional to p(u) over [0, last]: start + slope v, v in [0, 1].
        self.start = profile_at(signal, 0.0)
        end = profile_at(signal, self.last / duration) if self.last >= 0 else self.start
        self.slope = end - self.start
        self.linear = abs(self.slope) >= 1e-12 * max(1.0, abs(self.start))

    def draw(self, rng: random.Random) -> Occurrence | None:
        if rng.random() >= self.occurs:
            return None
        if self.linear:  # v with density proportional to start + slope v: the inverse of its CDF
            b, a = self.start, self.slope / 2
            target = rng.random() * (b + a)
            v = (-b + math.sqrt(max(0.0, b * b + 4 * a * target))) / (2 * a)
        else:
            v = rng.random()
        start = min(self.last, int(v * self.last))
        return Occurrence(start, start + _length(rng, self.shortest, self.longest, start, self.duration), self.name)


class _Repetitive:
    """A repetitive signal's draw on one duration: thinning of its Poisson process."""

    __slots__ = ("duration", "last", "limit", "longest", "name", "peak", "shortest", "signal")

    def __init__(self, signal: ir.Signal, duration: int) -> None:
        self.signal, self.name, self.duration = signal, signal.id, duration
        self.shortest, self.longest = _shortest(signal), _longest(signal)
        self.last = duration - self.shortest
        never = signal.probability_start <= 0 and signal.probability_end <= 0
        self.peak = 0.0 if never or self.last < 0 else max(start_rate(signal, 0.0), start_rate(signal, 1.0))
        self.limit = signal.max_occurrences

    def draw(self, rng: random.Random) -> list[Occurrence]:
        found: list[Occurrence] = []
        peak = self.peak
        if peak <= 0:
            return found
        signal, limit, last, duration = self.signal, self.limit, self.last, self.duration
        t = 0.0  # seconds
        while limit is None or len(found) < limit:
            t += rng.expovariate(peak)
            start = math.ceil(t * TICKS_PER_SECOND)
            if start > last:
                break
            if rng.random() * peak > start_rate(signal, start / duration):
                continue
            stop = start + _length(rng, self.shortest, self.longest, start, duration)
            found.append(Occurrence(start, stop, self.name))
            t = stop / TICKS_PER_SECOND
        return found


def _length(rng: random.Random, low: int, longest: int | None, start: int, duration: int) -> int:
    high = duration - start if longest is None else min(duration - start, longest)
    if high <= low:
        return low
    return round(rng.triangular(low, high, (low + high) / 2))


def draw_once(signal: ir.Signal, duration: int, rng: random.Random) -> Occurrence | None:
    """A once-only signal drawn from the prior (None: absent)."""
    return _Once(signal, duration).draw(rng)


def draw_repetitive(signal: ir.Signal, duration: int, rng: random.Random) -> list[Occurrence]:
    """A repetitive signal's occurrences drawn from the prior (thinning of its Poisson process)."""
    return _Repetitive(signal, duration).draw(rng)


class PriorDraw:
    """Draws of the prior for one model and duration (ticks), its constants computed once.
    Signals in ``absent`` are not drawn: the prior conditioned on their absence (signals are
    independent under the prior, so the others are drawn as they are)."""

    __slots__ = ("duration", "once", "repetitive")

    def __init__(self, model: ir.Model, duration: int, absent: Collection[str] = ()) -> None:
        self.duration = duration
        kept = [s for s in model.signals if s.id not in absent]
        # In the model's order, once-only signals first (one draw: the order is the stream's only).
        self.once = tuple(_Once(s, duration) for s in kept if not s.repetitive)
        self.repetitive = tuple(_Repetitive(s, duration) for s in kept if s.repetitive)

    def draw(self, rng: random.Random) -> Schedule:
        """One timeline of the prior."""
        occurrences = [o for o in (once.draw(rng) for once in self.once) if o is not None]
        for repetitive in self.repetitive:
            occurrences.extend(repetitive.draw(rng))
        return Schedule.of(self.duration, occurrences)


def prior_timeline(model: ir.Model, duration: int, rng: random.Random,
                   absent: Collection[str] = ()) -> Schedule:
    """One draw of the prior: every signal on its own (``duration`` in ticks; signals in
    ``absent`` left out, :class:`PriorDraw`, which a loop of draws should keep)."""
    return PriorDraw(model, duration, absent).draw(rng)

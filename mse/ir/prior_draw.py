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
import operator
import random
from collections.abc import Callable, Collection

from mse.ir import model as ir
from mse.ir.profile import MAX_PROBABILITY, RATE_UNIT, occurrence_probability, profile_at, start_rate
from mse.ir.schedule import TICKS_PER_SECOND, Occurrence, Schedule, to_ticks

# bound once: every rejection draw calls them
_sqrt, _log, _log1p, _ceil = math.sqrt, math.log, math.log1p, math.ceil
#: The order of Schedule.of: (start, signal, stop).
_ORDER = operator.attrgetter("start", "signal", "stop")

# Occurrence(start, stop, signal) without the frozen dataclass's __init__ (a Python frame that
# sets each field through object.__setattr__): its three slots set directly, the same object
# (equal, the same hash and order) at a third of the cost.  A rejection draw makes one per
# occurrence and throws most of them away.  tests/test_prior_draw.py checks the fields.
_new = object.__new__
_set_start, _set_stop, _set_signal = (getattr(Occurrence, field).__set__ for field in ("start", "stop", "signal"))


def _occurrence(start: int, stop: int, signal: str) -> Occurrence:
    occurrence: Occurrence = _new(Occurrence)
    _set_start(occurrence, start)
    _set_stop(occurrence, stop)
    _set_signal(occurrence, signal)
    return occurrence


def _shortest(signal: ir.Signal) -> int:
    return max(1, to_ticks(signal.min_duration))


def _longest(signal: ir.Signal) -> int | None:
    return None if signal.max_duration is None else to_ticks(signal.max_duration)


class _Once:
    """A once-only signal's draw on one duration, its constants computed once."""

    __slots__ = ("a", "b", "duration", "last", "linear", "longest", "name", "occurs", "shortest", "slope",
                 "start", "total")

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
        # the inverse CDF's constants (the same floats as computed in each draw before)
        self.b, self.a = self.start, self.slope / 2
        self.total = self.b + self.a

    def draw(self, rng: random.Random) -> Occurrence | None:
        random = rng.random
        if random() >= self.occurs:
            return None
        if self.linear:  # v with density proportional to start + slope v: the inverse of its CDF
            b, a = self.b, self.a
            target = random() * self.total
            v = (-b + _sqrt(max(0.0, b * b + 4 * a * target))) / (2 * a)
        else:
            v = random()
        last = self.last
        start = int(v * last)
        if start > last:
            start = last
        return _occurrence(start, start + _length(random, self.shortest, self.longest, start, self.duration), self.name)


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
        random = rng.random
        signal, limit, last, duration = self.signal, self.limit, self.last, self.duration
        # start_rate(signal, u), expovariate and _length written out (the same floats, the
        # same draws of rng.random in the same order): the loop of every rejection draw
        first, change = signal.probability_start, signal.probability_end - signal.probability_start
        shortest, longest, name = self.shortest, self.longest, self.name
        new, set_start, set_stop, set_signal = _new, _set_start, _set_stop, _set_signal
        # A flat profile's rate is the peak everywhere: the thinning draw never rejects.
        flat = change == 0.0
        t = 0.0  # seconds
        while limit is None or len(found) < limit:
            t += -_log(1.0 - random()) / peak
            start = _ceil(t * TICKS_PER_SECOND)
            if start > last:
                break
            if flat:
                random()
            else:
                u = start / duration
                if u > 1.0:
                    u = 1.0
                elif u < 0.0:  # (a NaN-free min/max clamp: u is a finite ratio of ticks)
                    u = 0.0
                p = first + change * u
                if random() * peak > -_log1p(-(p if p < MAX_PROBABILITY else MAX_PROBABILITY)) / RATE_UNIT:
                    continue
            # _length(random, shortest, longest, start, duration)
            high = duration - start
            if longest is not None and longest < high:
                high = longest
            if high <= shortest:
                stop = start + shortest
            else:
                v = random()
                if v > 0.5:
                    stop = start + round(high + (shortest - high) * _sqrt((1.0 - v) * 0.5))
                else:
                    stop = start + round(shortest + (high - shortest) * _sqrt(v * 0.5))
            occurrence = new(Occurrence)  # _occurrence(start, stop, name), written out
            set_start(occurrence, start)
            set_stop(occurrence, stop)
            set_signal(occurrence, name)
            found.append(occurrence)
            t = stop / TICKS_PER_SECOND
        return found


def _length(random: Callable[[], float], low: int, longest: int | None, start: int, duration: int) -> int:
    """Triangular on [low, high], the mode in the middle: ``random.triangular`` written out
    (one ``random()``; ``(mode - low) / (high - low)`` is exactly 0.5 on integer bounds)."""
    high = duration - start if longest is None else min(duration - start, longest)
    if high <= low:
        return low
    u = random()
    if u > 0.5:
        return round(high + (low - high) * _sqrt((1.0 - u) * 0.5))
    return round(low + (high - low) * _sqrt(u * 0.5))


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
        occurrences = []
        for once in self.once:
            occurrence = once.draw(rng)
            if occurrence is not None:
                occurrences.append(occurrence)
        for repetitive in self.repetitive:
            occurrences.extend(repetitive.draw(rng))
        # Schedule.of's order, with a C key function
        occurrences.sort(key=_ORDER)
        return Schedule(self.duration, tuple(occurrences))


def prior_timeline(model: ir.Model, duration: int, rng: random.Random,
                   absent: Collection[str] = ()) -> Schedule:
    """One draw of the prior: every signal on its own (``duration`` in ticks; signals in
    ``absent`` left out, :class:`PriorDraw`, which a loop of draws should keep)."""
    return PriorDraw(model, duration, absent).draw(rng)


def prior_signal(signal: ir.Signal, duration: int) -> _Once | _Repetitive:
    """One signal's prior draw on ``duration`` ticks (``.draw(rng)``: an occurrence or None for
    a once-only signal, the list of occurrences of a repetitive one)."""
    return _Repetitive(signal, duration) if signal.repetitive else _Once(signal, duration)


class RepetitiveDensity:
    """The density of a repetitive signal's occurrences under the prior, as far as a redraw of
    the starts in a window ``[low, top]`` needs it (mse/solve/chain.py).

    :class:`_Repetitive` draws a Poisson process by thinning: a start falls in tick ``k`` (the
    time interval ``((k-1)/T, k/T]`` seconds, T ticks per second) at intensity
    ``λ_k = start_rate(k / D)`` while the signal is free, for ``1 <= k <= last``; after a stop
    ``e`` it is free from tick ``e + 1``; at most ``limit`` starts.  The probability of the first
    start at tick ``s`` after a stop ``e`` is ``exp(-Λ(e+1, s-1)) (1 - exp(-λ_s / T))``, and of no
    start up to the end ``exp(-Λ(e+1, last))``, where ``Λ(i, j) = Σ_{k=i..j} λ_k / T``
    (:meth:`mass`, by the midpoint rule on the closed-form integral of ``-log(1 - p)`` for a
    linear ``p``: exact to about 1e-10 over an hour)."""

    __slots__ = ("draw", "duration", "flat", "last", "limit", "p0", "slope")

    def __init__(self, signal: ir.Signal, duration: int) -> None:
        self.draw = _Repetitive(signal, duration)
        self.duration, self.last, self.limit = duration, self.draw.last, signal.max_occurrences
        self.p0 = signal.probability_start
        self.slope = signal.probability_end - signal.probability_start
        #: Starts per tick when the profile is flat (most sets): Λ is then a product.
        self.flat = _rate(self.p0) / TICKS_PER_SECOND if self.slope == 0 else None

    def _p(self, tick: float) -> float:
        u = min(1.0, max(0.0, tick / self.duration))
        return self.p0 + self.slope * u

    def mass(self, first: int, last: int) -> float:
        """``Λ(first, last)``: expected thinned starts over the ticks ``first..last`` (both
        included, clipped to ``1..self.last``) for a signal free all along."""
        first, last = max(1, first), min(self.last, last)
        if last < first or self.draw.peak <= 0:
            return 0.0
        if self.flat is not None:
            return (last - first + 1) * self.flat
        return _rate_integral(self, first - 0.5, last + 0.5) / TICKS_PER_SECOND

    def run(self, rng: random.Random, free: int, top: int, remaining: int | None) -> list[Occurrence]:
        """The process from tick ``free`` (free from ``free + 1``) over starts up to ``top``,
        at most ``remaining`` starts: what :class:`_Repetitive` draws from there."""
        draw = self.draw
        peak = draw.peak
        found: list[Occurrence] = []
        if peak <= 0:
            return found
        signal, duration, top = draw.signal, draw.duration, min(top, draw.last)
        t = free / TICKS_PER_SECOND
        while remaining is None or len(found) < remaining:
            t += rng.expovariate(peak)
            start = math.ceil(t * TICKS_PER_SECOND)
            if start > top:
                break
            if rng.random() * peak > start_rate(signal, start / duration):
                continue
            stop = start + _length(rng.random, draw.shortest, draw.longest, start, duration)
            found.append(Occurrence(start, stop, draw.name))
            t = stop / TICKS_PER_SECOND
        return found

    def window_term(self, free: int, inside: list[Occurrence], after: tuple[Occurrence, Occurrence] | None,
                    top: int, remaining: int | None, total: int) -> float | None:
        """log(target / proposal) of the window's content ``inside`` (from the process of
        :meth:`run` from ``free`` up to ``top``), up to terms every content shares; ``after``:
        the first and the last kept occurrence after the window (None: none); ``total``: the
        signal's occurrences with this content.  None when the content overlaps the next kept
        occurrence (density 0)."""
        end = inside[-1].stop if inside else free
        if after and after[0].start <= end:
            return None
        target = -self.mass(end + 1, after[0].start - 1) if after else 0.0
        if self.limit is None or total < self.limit:
            target -= self.mass((after[1].stop if after else end) + 1, self.last)
        proposal = 0.0 if remaining is not None and len(inside) >= remaining else -self.mass(end + 1, top)
        return target - proposal


def _rate_integral(density: RepetitiveDensity, low: float, high: float) -> float:
    """∫ start_rate over ticks ``[low, high]`` (rate per second times ticks)."""
    p_low, p_high = density._p(low), density._p(high)
    if abs(p_high - p_low) < 1e-9:
        return (high - low) * _rate(0.5 * (p_low + p_high))
    cap = MAX_PROBABILITY
    if max(p_low, p_high) > cap:  # the rate is constant past the cap: split there
        cut = low + (high - low) * (cap - p_low) / (p_high - p_low)
        if min(p_low, p_high) >= cap:
            return (high - low) * _rate(cap)
        if p_low > cap:
            return (cut - low) * _rate(cap) + _rate_integral(density, cut, high)
        return _rate_integral(density, low, cut) + (high - cut) * _rate(cap)
    # ∫ -log(1 - p) dp = (1 - p) log(1 - p) + p; p is linear in the tick.
    return (_antiderivative(p_high) - _antiderivative(p_low)) * (high - low) / (p_high - p_low) / RATE_UNIT


def _rate(p: float) -> float:
    return -math.log1p(-min(p, MAX_PROBABILITY)) / RATE_UNIT


def _antiderivative(p: float) -> float:
    return (1.0 - p) * math.log1p(-p) + p

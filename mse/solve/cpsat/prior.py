"""Draws from the probability profile (:mod:`mse.ir.profile`) for the slots of one frame.

For every slot a solve decides, a :class:`SlotPrior` lists its options and their
probabilities under the *prior* (each signal on its own, before constraints), and one
option drawn from them with a start and a length:

* a **once-only** signal that has not occurred yet has one slot.  Its options: absent,
  starting in one of the window's time bins, or (when the window is not the last one)
  starting after the window ("later").  Their probabilities are the profile's, conditioned
  on the signal not having started before the window: occurrence ``mean(p)``, start density
  proportional to ``p(u)`` over the times where its ``min_duration`` still fits.
* a **repetitive** signal is drawn as the profile's renewal process: while free (not
  running, below ``max_occurrences``) it starts at ``p(u)`` starts per second.  Slot *k* of
  the window is the *k*-th drawn occurrence (absent past the last one); its options are
  absent or a bin, present with the probability that the window holds at least *k*
  occurrences (Poisson with the process's expected count) and in a bin in proportion to
  the rate there.
* lengths are triangular on ``[min_duration, max]`` with the mode at the midpoint, ``max``
  capped by the end of the timeline.

Drawing is exact: an unconstrained timeline made of the drawn options *is* a sample of the
prior.  :mod:`mse.solve.cpsat.objective` turns the options into perturbed scores whose
maximum is the drawn option, so that CP-SAT returns the draw whenever it is consistent and
otherwise trades options by their perturbed log-probabilities (perturb-and-MAP).
"""

from __future__ import annotations

import math
import random
from collections.abc import Mapping
from dataclasses import dataclass

from mse.ir import model as ir
from mse.ir.profile import never_occurs, occurrence_probability, profile_at, start_rate
from mse.ir.schedule import TICKS_PER_SECOND
from mse.solve.bounds import length_bounds

#: Start bins per window: one per BIN_TICKS, at least 1 and at most MAX_BINS.
BIN_TICKS = 500
MAX_BINS = 20
#: A log-probability standing for "impossible under the prior" (an option constraints may
#: still force, at this cost).
IMPOSSIBLE = math.log(1e-4)

ABSENT = -1


@dataclass(frozen=True, slots=True)
class SlotPrior:
    """The prior of one decided slot and its drawn option.

    ``choice`` is ABSENT, a bin index, or ``len(bins)`` for "later" (``log_later`` is
    then not None).  ``targets`` holds, per bin, the start the slot aims at in that bin
    (the drawn start in the drawn bin); ``length`` the length it aims at."""

    signal: str
    index: int
    bins: tuple[tuple[int, int], ...]
    log_bins: tuple[float, ...]
    log_absent: float
    log_later: float | None
    choice: int
    targets: tuple[int, ...]
    length: int
    never: bool = False

    @property
    def later(self) -> int:
        return len(self.bins)

    @property
    def present(self) -> bool:
        return self.choice != ABSENT

    @property
    def start(self) -> int:
        return self.targets[self.choice] if 0 <= self.choice < len(self.bins) else -1


def window_bins(begin: int, end: int) -> tuple[tuple[int, int], ...]:
    count = max(1, min(MAX_BINS, (end - begin) // BIN_TICKS))
    edges = [begin + (end - begin) * b // count for b in range(count + 1)]
    return tuple((edges[b], edges[b + 1]) for b in range(count) if edges[b + 1] > edges[b])


def _log(probability: float) -> float:
    return math.log(probability) if probability > 1e-12 else IMPOSSIBLE


def draw_length(signal: ir.Signal, start: int, duration: int, rng: random.Random, *, mode: str) -> int:
    """A triangular length on [min, max] (max capped by the end of the timeline)."""
    low, high = length_bounds(signal, duration)
    high = min(high, duration - start)
    if high <= low:
        return max(1, high)
    if mode == "likely":
        return (low + high) // 2
    return round(rng.triangular(low, high, (low + high) / 2))


class _OnceProfile:
    """Start distribution of a once-only signal: density p(t / D) on [0, last]."""

    def __init__(self, signal: ir.Signal, duration: int) -> None:
        low, _ = length_bounds(signal, duration)
        self.signal = signal
        self.duration = duration
        self.last = duration - low  # latest start where min_duration fits
        self.a = signal.probability_start
        self.slope = (signal.probability_end - signal.probability_start) / max(1, duration)
        self.total = self.cdf(self.last) if self.last >= 0 else 0.0  # 0: it never fits

    def cdf(self, t: int) -> float:
        """Unnormalised mass of starts in [0, t]."""
        x = min(max(0, t), self.last)
        return self.a * x + self.slope * x * x / 2

    def mass(self, lo: int, hi: int) -> float:
        """Probability that the start lies in [lo, hi)."""
        if self.total <= 0:
            return 0.0
        return max(0.0, (self.cdf(hi) - self.cdf(lo)) / self.total)

    def sample(self, lo: int, hi: int, rng: random.Random, *, mode: str) -> int:
        """A start in [lo, min(hi, last + 1)) with density proportional to p."""
        top = min(hi, self.last + 1)
        if top <= lo + 1:
            return lo
        if mode == "likely":
            return (lo + top - 1) // 2
        peak = max(profile_at(self.signal, lo / self.duration), profile_at(self.signal, top / self.duration))
        for _ in range(64):
            t = rng.randrange(lo, top)
            if mode == "random" or rng.random() * peak <= profile_at(self.signal, t / self.duration):
                return t
        return rng.randrange(lo, top)


def _pick(probabilities: list[float], rng: random.Random, mode: str) -> int:
    """Index drawn in proportion to ``probabilities`` (``likely``: the largest; ``random``:
    uniform).  The probabilities themselves, not their logarithms floored at IMPOSSIBLE: at
    3,600 s a once-only signal starts in a given 0.5 s bin with probability p / 7,200, below
    that floor, and weighing such bins as impossible left no bin to draw (Greta's panic_fear:
    no once-only signal at all in an hour)."""
    if mode == "likely":
        return max(range(len(probabilities)), key=lambda i: probabilities[i])
    if mode == "random":
        return rng.randrange(len(probabilities))
    weights = [max(0.0, v) for v in probabilities]
    total = sum(weights)
    if total <= 0:
        return 0
    x = rng.random() * total
    for index, weight in enumerate(weights):
        x -= weight
        if x < 0:
            return index
    return len(weights) - 1


def once_prior(signal: ir.Signal, duration: int, begin: int, end: int, rng: random.Random,
               *, mode: str = "sample") -> SlotPrior:
    """The one slot of a once-only signal not yet occurred at ``begin``."""
    bins = window_bins(begin, end)
    profile = _OnceProfile(signal, duration)
    never = never_occurs(signal) or profile.total <= 0
    p = occurrence_probability(signal)
    before = profile.mass(0, begin)
    remaining = max(1e-12, 1.0 - p * before)
    bin_probabilities = [p * profile.mass(lo, hi) / remaining for lo, hi in bins]
    later = p * profile.mass(end, duration + 1) / remaining if end < duration else None
    absent = max(0.0, 1.0 - sum(bin_probabilities) - (later or 0.0))
    log_bins = [_log(x) for x in bin_probabilities]
    log_later = None if later is None else _log(later)
    options = [absent, *bin_probabilities] + ([] if later is None else [later])
    picked = ABSENT if never else _pick(options, rng, mode) - 1
    targets = tuple(profile.sample(lo, hi, rng, mode=mode) for lo, hi in bins)
    start = targets[picked] if 0 <= picked < len(bins) else targets[0]
    return SlotPrior(signal.id, 0, bins, tuple(log_bins), _log(absent), log_later, picked, targets,
                     draw_length(signal, start, duration, rng, mode=mode), never)


def draw_once(signal: ir.Signal, duration: int, rng: random.Random) -> tuple[int, int] | None:
    """A once-only signal over the whole timeline, drawn from the prior: absent (None) or
    one occurrence (start, stop)."""
    profile = _OnceProfile(signal, duration)
    if never_occurs(signal) or profile.total <= 0 or rng.random() >= occurrence_probability(signal):
        return None
    start = profile.sample(0, duration, rng, mode="sample")
    return start, start + draw_length(signal, start, duration, rng, mode="sample")


def _mean_length(signal: ir.Signal, duration: int) -> float:
    low, high = length_bounds(signal, duration)
    return (low + min(high, duration)) / 2


def renewal_starts(signal: ir.Signal, duration: int, free_from: int, end: int, room: int | None,
                   rng: random.Random, *, mode: str = "sample") -> list[tuple[int, int]]:
    """Occurrences (start, stop) of the profile's renewal process starting in [free_from, end):
    while free, starts at :func:`~mse.ir.profile.start_rate` per second (a start within a free
    second with probability p(u))."""
    low, _ = length_bounds(signal, duration)
    last = duration - low
    peak = max(start_rate(signal, 0.0), start_rate(signal, 1.0))
    found: list[tuple[int, int]] = []
    if peak <= 0 or (mode == "likely" and max(signal.probability_start, signal.probability_end) < 0.5):
        return found
    t = float(free_from)
    while room is None or len(found) < room:
        if mode == "likely":
            t += TICKS_PER_SECOND / peak
        else:
            t += rng.expovariate(peak) * TICKS_PER_SECOND
            if t >= end:
                break
            if mode != "random" and rng.random() * peak > start_rate(signal, t / duration):
                continue
        start = math.ceil(t)
        if start >= end or start > last:
            break
        length = draw_length(signal, start, duration, rng, mode=mode)
        found.append((start, start + length))
        t = float(start + length)
    return found


def _poisson_tail(mean: float, k: int) -> float:
    """P(N >= k) for N ~ Poisson(mean)."""
    if k <= 0:
        return 1.0
    term = math.exp(-mean)
    below = term
    for n in range(1, k):
        term *= mean / n
        below += term
    return max(0.0, 1.0 - below)


def expected_starts(signal: ir.Signal, duration: int, begin: int, end: int, free_from: int) -> float:
    """Expected starts of a repetitive signal's renewal process in [max(begin, free_from), end):
    the start rate at the span's middle, thinned by the time occurrences keep it busy."""
    usable = max(0, end - max(begin, free_from))
    if usable <= 0:
        return 0.0
    rate = start_rate(signal, (begin + end) / 2 / duration)
    free = 1.0 / (1.0 + rate * _mean_length(signal, duration) / TICKS_PER_SECOND)
    return rate * free * usable / TICKS_PER_SECOND


def repetitive_priors(signal: ir.Signal, duration: int, begin: int, end: int, free_from: int,
                      room: int | None, slots: int, drawn: list[tuple[int, int]],
                      rng: random.Random) -> list[SlotPrior]:
    """Priors of ``slots`` window slots of a repetitive signal whose draw is ``drawn``."""
    bins = window_bins(begin, end)
    weights = [expected_starts(signal, duration, lo, min(hi, end), free_from) for lo, hi in bins]
    expected = sum(weights)
    total = sum(weights) or 1.0
    never = never_occurs(signal)
    priors = []
    for k in range(slots):
        present = min(1.0, _poisson_tail(expected, k + 1)) if room is None or k < room else 0.0
        log_bins = tuple(_log(present * w / total) for w in weights)
        targets = tuple(rng.randrange(lo, hi) for lo, hi in bins)
        if k < len(drawn):
            start, stop = drawn[k]
            choice = next(b for b, (lo, hi) in enumerate(bins) if lo <= start < hi)
            targets = (*targets[:choice], start, *targets[choice + 1:])
            length = stop - start
        else:
            choice = ABSENT
            length = draw_length(signal, targets[0], duration, rng, mode="sample")
        priors.append(SlotPrior(signal.id, k, bins, log_bins, _log(1.0 - present), None, choice,
                                targets, length, never))
    return priors


def frame_priors(
    model: ir.Model,
    duration: int,
    begin: int,
    end: int,
    free_from: Mapping[str, int],
    committed: Mapping[str, int],
    rng: random.Random,
    *,
    mode: str = "sample",
    extra: int = 1,
) -> dict[str, list[SlotPrior]]:
    """Window-slot priors of every signal for the frame [begin, end) (``extra`` slots beyond a
    repetitive signal's draw let constraints add occurrences)."""
    priors: dict[str, list[SlotPrior]] = {}
    for signal in model.signals:
        low, _ = length_bounds(signal, duration)
        start_from = max(begin, free_from.get(signal.id, 0))
        if low > duration or start_from > duration - low:
            priors[signal.id] = []
            continue
        if not signal.repetitive:
            priors[signal.id] = [] if committed.get(signal.id, 0) else [
                once_prior(signal, duration, begin, end, rng, mode=mode)]
            continue
        room = None if signal.max_occurrences is None else signal.max_occurrences - committed.get(signal.id, 0)
        if room is not None and room <= 0:
            priors[signal.id] = []
            continue
        drawn = [] if never_occurs(signal) else renewal_starts(signal, duration, start_from, end, room, rng,
                                                               mode=mode)
        fit = max(1, (end - start_from) // max(1, low) + 1)
        slots = min(len(drawn) + extra, fit, room if room is not None else fit)
        priors[signal.id] = repetitive_priors(signal, duration, begin, end, start_from, room, max(slots, len(drawn)),
                                              drawn, rng)
    return priors

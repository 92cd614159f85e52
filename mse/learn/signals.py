"""Signals from a corpus: durations, probability profile, repetitivity (docs/learn.md).

**Durations.**  ``min_duration``/``max_duration`` are the shortest and longest observed
lengths at confidence 1; below 1, Tukey's fences (the quartiles minus/plus 1.5 interquartile
ranges, clipped to the observed range), so that an outlier (a mis-set annotation) does not
stretch the range while the bulk is never cut; rounded outward to :data:`RESOLUTION` s.
The occurrences left outside are reported.

**Probabilities**, under the sampler's definition (``mse/ir/profile.py``): the profile is
the line ``p(u) = p_start + (p_end - p_start) u`` over relative time ``u = t / D``.

* once-only signal: it occurs with probability ``(p_start + p_end) / 2`` and starts with
  density proportional to ``p(u)``, whose mean is ``(p_start + 2 p_end) / (3 (p_start +
  p_end))``.  The method of moments matches both: the fraction ``f`` of sequences where the
  signal occurs and the mean relative start ``m`` give ``p_start = 2 f (2 - 3 m)``,
  ``p_end = 2 f (3 m - 1)`` (clipped so that both stay in [0, 1] with the same sum);
* repetitive signal: it starts at ``p(u)`` per free second (free: not running, below
  ``max_occurrences``).  The starts are a Poisson process of intensity ``a + c u`` over the
  free time; matching the number of starts and the sum of their ``u`` with their
  expectations over the observed free time (two linear equations) gives ``a`` and ``c``.

The corpus was made under constraints, so these raw estimates see the prior through the
constraints; :mod:`mse.learn.calibrate` corrects them by sampling the learned set.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from mse.ir.model import MotionLeaf, Signal
from mse.learn.corpus import Corpus
from mse.learn.stats import CorpusArrays, Floats

#: Durations and offsets are rounded (outward) to this many seconds.
RESOLUTION = 0.05
#: Below confidence 1, lengths beyond the quartiles by more than this many interquartile
#: ranges are outliers (Tukey's fences).
TUKEY_FENCE = 1.5


@dataclass(frozen=True)
class LearnedSignal:
    signal: Signal
    sequences: int  # sequences where it occurs
    occurrences: int
    level: float  # (p_start + p_end) / 2 as estimated
    mean_start: float  # mean relative start of its occurrences
    evidence: str


def floor_to(value: float, step: float = RESOLUTION) -> float:
    return round(math.floor(value / step + 1e-9) * step, 3)


def ceil_to(value: float, step: float = RESOLUTION) -> float:
    return round(math.ceil(value / step - 1e-9) * step, 3)


def duration_range(lengths: Floats, confidence: float) -> tuple[float, float]:
    """All observed lengths at confidence 1; below, Tukey's fences (quartiles -/+ 1.5 times
    the interquartile range) clipped to the observed range: outliers are cut, the bulk never."""
    shortest, longest = float(lengths.min()), float(lengths.max())
    if confidence >= 1.0 or len(lengths) < 4:
        return shortest, longest
    first, third = (float(q) for q in np.quantile(lengths, (0.25, 0.75)))
    spread = TUKEY_FENCE * (third - first)
    return max(shortest, first - spread), min(longest, third + spread)


def profile_from(level: float, mean_start: float) -> tuple[float, float]:
    """``(p_start, p_end)`` with ``(p_start + p_end) / 2 = level`` and mean relative start as
    close to ``mean_start`` as the range [0, 1] of both allows."""
    level = min(1.0, max(0.0, level))
    if level <= 0:
        return 0.0, 0.0
    m = min(2 / 3, max(1 / 3, mean_start))
    total = 2 * level
    start = total * (2 - 3 * m)
    start = min(min(1.0, total), max(max(0.0, total - 1.0), start))
    return round(start, 3), round(total - start, 3)


def profile_mean(p_start: float, p_end: float) -> float:
    total = p_start + p_end
    return 0.5 if total <= 0 else (p_start + 2 * p_end) / (3 * total)


def learn_signals(corpus: Corpus, arrays: CorpusArrays, confidence: float) -> list[LearnedSignal]:
    learned = []
    n = arrays.size
    for signal_id, info in corpus.signals.items():
        data = arrays.signals[signal_id]
        sequences = int(data.present.sum())
        total = int(data.count.sum())
        lengths = data.lengths / 1000.0
        low, high = duration_range(lengths, confidence)
        min_duration = floor_to(low)
        max_duration = max(ceil_to(high), min_duration)
        most = int(data.count.max())
        repetitive = most > 1
        mean_start = float(data.relative_starts.mean())
        if repetitive:
            p_start, p_end = _rate_profile(corpus, signal_id, most)
            level = (p_start + p_end) / 2
        else:
            level = sequences / n
            p_start, p_end = profile_from(level, mean_start)
        if p_start + p_end <= 0:  # it did occur: never write an inactive signal (W301)
            p_start = p_end = 0.001
        signal = Signal(
            id=signal_id,
            modality=info.modality,
            lexeme=info.lexeme,
            min_duration=min_duration,
            max_duration=round(max_duration, 3),
            probability_start=p_start,
            probability_end=p_end,
            repetitivity=1 if repetitive else 0,
            max_occurrences=most if repetitive else None,
            motion=MotionLeaf(info.motion) if info.motion else None,
        )
        evidence = (
            f"in {sequences} of {n} sequences ({total} occurrences, at most {most} in one); "
            f"lengths {lengths.min():.3g}-{lengths.max():.3g} s, median {np.median(lengths):.3g} s; "
            f"mean relative start {mean_start:.2f}"
        )
        learned.append(LearnedSignal(signal, sequences, total, level, mean_start, evidence))
    return learned


def _rate_profile(corpus: Corpus, signal_id: str, most: int) -> tuple[float, float]:
    """Starts per free second ``a + c u`` fitted by matching the count and the first moment."""
    starts = exposure0 = exposure1 = exposure2 = first = 0.0
    for sequence in corpus.sequences:
        duration = sequence.duration / 1000.0
        occurrences = sequence.occurrences.get(signal_id, ())
        free_from = 0.0
        for number, (start, stop) in enumerate(occurrences, 1):
            s = start / 1000.0
            e0, e1, e2 = _moments(free_from, s, duration)
            exposure0, exposure1, exposure2 = exposure0 + e0, exposure1 + e1, exposure2 + e2
            starts += 1
            first += s / duration
            free_from = stop / 1000.0
            if number >= most:
                free_from = duration
        e0, e1, e2 = _moments(free_from, duration, duration)
        exposure0, exposure1, exposure2 = exposure0 + e0, exposure1 + e1, exposure2 + e2
    determinant = exposure0 * exposure2 - exposure1 * exposure1
    if exposure0 <= 0:
        return 0.0, 0.0
    if abs(determinant) < 1e-12 * max(1.0, exposure0 * exposure2):
        rate = starts / exposure0
        return round(min(1.0, rate), 3), round(min(1.0, rate), 3)
    a = (starts * exposure2 - first * exposure1) / determinant
    c = (exposure0 * first - exposure1 * starts) / determinant
    p_start = min(1.0, max(0.0, a))
    p_end = min(1.0, max(0.0, a + c))
    return round(p_start, 3), round(p_end, 3)


def _moments(t1: float, t2: float, duration: float) -> tuple[float, float, float]:
    """``∫ dt``, ``∫ u dt`` and ``∫ u² dt`` over [t1, t2] seconds, ``u = t / duration``."""
    if t2 <= t1:
        return 0.0, 0.0, 0.0
    return t2 - t1, (t2 * t2 - t1 * t1) / (2 * duration), (t2**3 - t1**3) / (3 * duration * duration)


def with_profile(learned: LearnedSignal, p_start: float, p_end: float) -> LearnedSignal:
    return replace(learned, signal=replace(learned.signal, probability_start=p_start, probability_end=p_end))

"""Calibrating the probability profiles by sampling the learned set (docs/learn.md).

The corpus shows each signal *through* the constraints (a smile that needs an exhale occurs
less often than its prior says), and the learned set's sampler applies the same constraints
again, with its own approximations (the walk loses a once-only signal whose constraints fail
at its candidacy).  So the raw estimates of :mod:`mse.learn.signals` are corrected by
simulation: sample the learned set at the corpus' typical duration with the default sampler,
compare each signal's occurrence rate (starts per sequence: for a once-only signal the
fraction of sequences where it occurs) and mean relative start with the corpus, and adjust
every signal's profile at once:

* its level by the ratio of rates (``want / got``), a full step at first and half as large
  after each change of direction (the signals interact through the constraints, and a
  signal's step must not oscillate), doubled when it never occurred; the level stays in
  what the profile can be (at most 1, at most 0.5 when ``probability_start`` is held at 0);
* its mean start by half the difference.

Rounds stop when every signal is within its tolerance (:func:`tolerance`: twice the sampling
error of the round, at least :data:`STOP_ERROR`) or after ``rounds`` adjustments; the round
closest to the corpus is kept.  Each round uses its own seeds (``seed + round * samples``),
so the result is reproduced by the seed and does not fit one sample's noise.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, replace

from mse import progress
from mse.ir import model as ir
from mse.ir.schedule import Schedule, to_seconds
from mse.learn.corpus import Corpus
from mse.learn.signals import profile_from, profile_mean

#: A round whose every signal is this close to the corpus (or within twice its sampling
#: error, if larger) ends the calibration.
STOP_ERROR = 0.02
#: Steps of the level, as powers of the ratio of rates: full, then halved at each change of
#: direction, never below this.
SMALLEST_STEP = 0.25


@dataclass(frozen=True)
class Profile:
    """What is compared: mean starts per sequence and mean relative start, per signal."""

    rate: Mapping[str, float]
    mean_start: Mapping[str, float]


def corpus_profile(corpus: Corpus) -> Profile:
    return _profile(
        [(s.duration, [(sid, o[0]) for sid, occ in s.occurrences.items() for o in occ]) for s in corpus.sequences],
        list(corpus.signals),
    )


def schedules_profile(schedules: Sequence[Schedule], signals: list[str]) -> Profile:
    return _profile([(s.duration, [(o.signal, o.start) for o in s.occurrences]) for s in schedules], signals)


def _profile(sequences: list[tuple[int, list[tuple[str, int]]]], signals: list[str]) -> Profile:
    counts = dict.fromkeys(signals, 0)
    sums = dict.fromkeys(signals, 0.0)
    for duration, starts in sequences:
        for signal, start in starts:
            if signal in counts:
                counts[signal] += 1
                sums[signal] += start / duration
    n = max(1, len(sequences))
    return Profile(
        {s: counts[s] / n for s in signals},
        {s: (sums[s] / counts[s] if counts[s] else 0.5) for s in signals},
    )


def tolerance(rate: float, samples: int) -> float:
    """How far a round's rate may be from the corpus' for the calibration to stop: twice the
    standard error of a rate measured on ``samples`` sequences (binomial below one start
    per sequence, Poisson above), at least :data:`STOP_ERROR`."""
    spread = math.sqrt(rate * (1 - rate)) if rate < 1 else math.sqrt(rate)
    return max(STOP_ERROR, 2 * spread / math.sqrt(max(1, samples)))


def distance(target: Profile, sampled: Profile) -> float:
    total = 0.0
    for signal, rate in target.rate.items():
        total += abs(sampled.rate[signal] - rate) / max(rate, 0.05)
        total += abs(sampled.mean_start[signal] - target.mean_start[signal]) * min(1.0, rate)
    return total


def calibrate(
    model: ir.Model, corpus: Corpus, *, rounds: int = 8, samples: int = 300, seed: int = 0,
    late: Collection[str] = (),
) -> tuple[ir.Model, list[str]]:
    """The model with calibrated probabilities, and notes on what happened.  Signals in
    ``late`` keep ``probability_start`` 0 (the constraints never let them start early)."""
    from mse.diagnostics import MseError
    from mse.solve.protocol import SolveRequest, get_solver

    target = corpus_profile(corpus)
    signals = [s.id for s in model.signals]
    duration = to_seconds(corpus.typical_duration)
    solver = get_solver("greedy")
    best: tuple[float, ir.Model] | None = None
    notes: list[str] = []
    current = with_late(model, late)
    steps = dict.fromkeys(signals, 1.0)
    previous: dict[str, float] = {}
    for round_number in progress.each(range(rounds + 1), "calibrate", unit="round"):
        try:
            schedules = solver.solve(current, SolveRequest(duration=duration, seed=seed,
                                                           count=samples)).schedules
        except MseError as error:
            notes.append(f"calibration stopped: the learned set could not be sampled ({error})")
            break
        sampled = schedules_profile(schedules, signals)
        score = distance(target, sampled)
        if best is None or score < best[0]:
            best = (score, current)
        errors = {s: target.rate[s] - sampled.rate[s] for s in signals}
        worst = max(signals, key=lambda s: abs(errors[s]), default=None)
        notes.append(f"round {round_number}: distance {score:.3f}"
                     + (f", largest rate difference {abs(errors[worst]):.3f} ({worst})" if worst else ""))
        if all(abs(errors[s]) <= tolerance(target.rate[s], samples) for s in signals) or round_number == rounds:
            break
        for signal in signals:
            if signal in previous and previous[signal] * errors[signal] < 0:
                steps[signal] = max(SMALLEST_STEP, steps[signal] / 2)
        previous = errors
        current = _adjusted(current, target, sampled, steps, late)
    return (best[1] if best is not None else model), notes


def with_late(model: ir.Model, late: Collection[str]) -> ir.Model:
    """``probability_start`` 0 for the signals in ``late``, their level kept as far as the
    profile allows (at most 0.5)."""
    if not late:
        return model
    return replace(model, signals=tuple(
        replace(s, probability_start=0.0, probability_end=round(min(1.0, s.probability_start + s.probability_end), 3))
        if s.id in late else s for s in model.signals))


def _adjusted(model: ir.Model, target: Profile, sampled: Profile, steps: Mapping[str, float],
              late: Collection[str]) -> ir.Model:
    signals = []
    for signal in model.signals:
        a, b = signal.probability_start, signal.probability_end
        level, mean = (a + b) / 2, profile_mean(a, b)
        want, got = target.rate[signal.id], sampled.rate[signal.id]
        if got > 0:
            level = level * (want / got) ** steps[signal.id]
            mean = mean + (target.mean_start[signal.id] - sampled.mean_start[signal.id]) / 2
        else:
            level = level * 2 + 0.01
        if signal.id in late:
            p_start, p_end = 0.0, round(min(1.0, 2 * level), 3)
        else:
            p_start, p_end = profile_from(level, mean)
        if p_start + p_end <= 0:
            p_start = p_end = 0.001
        signals.append(replace(signal, probability_start=p_start, probability_end=p_end))
    return replace(model, signals=tuple(signals))

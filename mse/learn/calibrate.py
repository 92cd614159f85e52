"""Calibrating the probability profiles by sampling the learned set (docs/learn.md).

The corpus shows each signal *through* the constraints (a smile that needs an exhale occurs
less often than its prior says); the learned set's sampler applies the same constraints
again.  So the raw estimates of :mod:`mse.learn.signals` are corrected in a few rounds:
sample the learned set at the corpus' typical duration with the default sampler, compare
each signal's occurrence rate (starts per sequence for a repetitive one) and mean relative
start with the corpus, scale the profile's level by (the square root of) the ratio of rates
and shift its mean
by (half) the difference, and keep the round whose samples are closest to the corpus.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

from mse import progress
from mse.ir import model as ir
from mse.ir.schedule import Schedule, to_seconds
from mse.learn.corpus import Corpus
from mse.learn.signals import profile_from, profile_mean


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


def distance(target: Profile, sampled: Profile) -> float:
    total = 0.0
    for signal, rate in target.rate.items():
        total += abs(sampled.rate[signal] - rate) / max(rate, 0.05)
        total += abs(sampled.mean_start[signal] - target.mean_start[signal]) * min(1.0, rate)
    return total


def calibrate(
    model: ir.Model, corpus: Corpus, *, rounds: int = 4, samples: int = 300, seed: int = 0
) -> tuple[ir.Model, list[str]]:
    """The model with calibrated probabilities, and notes on what happened."""
    from mse.diagnostics import MseError
    from mse.solve.protocol import SolveRequest, get_solver

    target = corpus_profile(corpus)
    signals = [s.id for s in model.signals]
    duration = to_seconds(corpus.typical_duration)
    solver = get_solver("greedy")
    best: tuple[float, ir.Model] | None = None
    notes: list[str] = []
    current = model
    for round_number in progress.each(range(rounds + 1), "calibrate", unit="round"):
        try:
            schedules = solver.solve(current, SolveRequest(duration=duration, seed=seed + round_number * samples,
                                                           count=samples)).schedules
        except MseError as error:
            notes.append(f"calibration stopped: the learned set could not be sampled ({error})")
            break
        sampled = schedules_profile(schedules, signals)
        score = distance(target, sampled)
        if best is None or score < best[0]:
            best = (score, current)
        notes.append(f"round {round_number}: distance {score:.3f}")
        if round_number == rounds:
            break
        current = _adjusted(current, target, sampled)
    return (best[1] if best is not None else model), notes


def _adjusted(model: ir.Model, target: Profile, sampled: Profile) -> ir.Model:
    signals = []
    for signal in model.signals:
        a, b = signal.probability_start, signal.probability_end
        level, mean = (a + b) / 2, profile_mean(a, b)
        want, got = target.rate[signal.id], sampled.rate[signal.id]
        # Half steps (square root of the ratio): the signals interact through the constraints,
        # and full steps overshoot.
        level = level * (want / got) ** 0.5 if got > 0 else min(1.0, level * 1.5 + 0.01)
        if got > 0:
            mean = mean + (target.mean_start[signal.id] - sampled.mean_start[signal.id]) / 2
        p_start, p_end = profile_from(level, mean)
        if p_start + p_end <= 0:
            p_start = p_end = 0.001
        signals.append(replace(signal, probability_start=p_start, probability_end=p_end))
    return replace(model, signals=tuple(signals))

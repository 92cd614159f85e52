"""Calibrating the probability profiles by sampling the learned set (docs/learn.md).

The corpus shows each signal *through* the constraints (a smile that needs an exhale occurs
less often than its prior says), and the learned set's sampler applies the same constraints
again, with its own approximations (the walk loses a once-only signal whose constraints fail
at its candidacy).  So the raw estimates of :mod:`mse.learn.signals` are corrected by
simulation: sample the learned set at the corpus' typical duration with the default sampler,
compare each signal's rate (the fraction of sequences where it occurs; starts per sequence
for a repetitive signal present in nearly all of them, :func:`counted_signals`) and mean
relative start with the corpus, and adjust every signal's profile at once:

* its level by the ratio of rates (``want / got``), a half step (its square root) at first
  and half as large again after each change of direction (the signals interact through the constraints, and a
  signal's step must not oscillate), doubled when it never occurred; the level stays in
  what the profile can be (at most 1, at most 0.5 when ``probability_start`` is held at 0);
* its mean start by half the difference.

Rounds stop when every signal is within its tolerance (:func:`tolerance`: twice the sampling
error of the round, at least :data:`STOP_ERROR`), after :data:`PATIENCE` rounds without
progress or after ``rounds`` adjustments; the round closest to the corpus is kept.  Every
round samples the same seeds (common random numbers: a difference between two rounds is the
probabilities', not the draws'), so the result is reproduced by the seed.

A signal whose rate its probabilities cannot move (a learned rule forces or blocks it in the
sampler) is found afterwards by :func:`release_rules`, which releases the rule responsible.
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
#: Rounds without a new closest one that end the calibration (the rates no longer follow
#: the probabilities: a rule forces or blocks a signal, see :func:`release_rules`).
PATIENCE = 3
#: Steps of the level, as powers of the ratio of rates: half at first (the square root of the
#: ratio), halved again at each change of direction, never below SMALLEST_STEP.  Full first
#: steps overshot where the sampler draws exactly (the rejection stage, docs/sampler.md):
#: random9's calibration moved away from the corpus from its first round (distance 4.0 → 7.1)
#: and ended with s14 at 0.08 against 0.31; half steps reach 1.3.
FIRST_STEP = 0.5
SMALLEST_STEP = 0.25


@dataclass(frozen=True)
class Profile:
    """What is compared, per signal: its rate (starts per sequence for a counted signal,
    the fraction of sequences where it occurs for the others), the fraction of sequences
    where it occurs (the same as the rate for the others) and its mean relative start."""

    rate: Mapping[str, float]
    mean_start: Mapping[str, float]
    presence: Mapping[str, float]


#: A repetitive signal present in at least this fraction of the corpus' sequences is
#: calibrated on its starts per sequence: its presence says nothing about its level there.
COUNTED_PRESENCE = 0.97


def counted_signals(model: ir.Model, corpus: Corpus) -> frozenset[str]:
    """The signals whose rate is their starts per sequence (the others': the fraction of
    sequences where they occur)."""
    n = max(1, len(corpus.sequences))
    present = {s: sum(1 for q in corpus.sequences if q.occurrences.get(s)) / n for s in corpus.signals}
    return frozenset(s.id for s in model.signals if s.repetitivity and present.get(s.id, 0.0) >= COUNTED_PRESENCE)


def corpus_profile(corpus: Corpus, counted: Collection[str] = ()) -> Profile:
    return _profile(
        [(s.duration, [(sid, o[0]) for sid, occ in s.occurrences.items() for o in occ]) for s in corpus.sequences],
        list(corpus.signals), counted,
    )


def schedules_profile(schedules: Sequence[Schedule], signals: list[str], counted: Collection[str] = ()) -> Profile:
    return _profile([(s.duration, [(o.signal, o.start) for o in s.occurrences]) for s in schedules], signals,
                    counted)


def _profile(sequences: list[tuple[int, list[tuple[str, int]]]], signals: list[str],
             counted: Collection[str]) -> Profile:
    """Per signal: starts per sequence (``counted`` signals) or the fraction of sequences
    where it occurs (the others), and the mean relative start."""
    counts = dict.fromkeys(signals, 0)
    present = dict.fromkeys(signals, 0)
    sums = dict.fromkeys(signals, 0.0)
    for duration, starts in sequences:
        for signal in {signal for signal, _ in starts if signal in present}:
            present[signal] += 1
        for signal, start in starts:
            if signal in counts:
                counts[signal] += 1
                sums[signal] += start / duration
    n = max(1, len(sequences))
    return Profile(
        {s: (counts[s] if s in counted else present[s]) / n for s in signals},
        {s: (sums[s] / counts[s] if counts[s] else 0.5) for s in signals},
        {s: present[s] / n for s in signals},
    )


def tolerance(rate: float, samples: int) -> float:
    """How far a round's rate may be from the corpus' for the calibration to stop: twice the
    standard error of a rate measured on ``samples`` sequences (binomial below one start
    per sequence, Poisson above), at least :data:`STOP_ERROR`."""
    spread = math.sqrt(rate * (1 - rate)) if rate < 1 else math.sqrt(rate)
    return max(STOP_ERROR, 2 * spread / math.sqrt(max(1, samples)))


def distance(target: Profile, sampled: Profile) -> float:
    """Relative rate differences plus mean start differences; for a counted signal its
    presence's difference too (calibrated on its starts, it must still occur as often)."""
    total = 0.0
    for signal, rate in target.rate.items():
        total += abs(sampled.rate[signal] - rate) / max(rate, 0.05)
        total += abs(sampled.mean_start[signal] - target.mean_start[signal]) * min(1.0, rate)
        presence = target.presence[signal]
        if presence != rate:
            total += abs(sampled.presence[signal] - presence) / max(presence, 0.05)
    return total


@dataclass(frozen=True)
class Calibration:
    """The calibrated model, notes on the rounds, and each signal's rate difference (corpus
    minus sampled) in the kept round (empty when no round could be sampled)."""

    model: ir.Model
    notes: list[str]
    errors: Mapping[str, float]
    score: float


def sample_profile(model: ir.Model, duration: float, samples: int, seed: int,
                   counted: Collection[str] = ()) -> Profile:
    """Rates and mean starts of ``samples`` timelines of the default sampler (MseError when
    the set cannot be sampled)."""
    from mse.solve.protocol import SolveRequest, get_solver

    schedules = get_solver("greedy").solve(model, SolveRequest(duration=duration, seed=seed, count=samples)).schedules
    return schedules_profile(schedules, [s.id for s in model.signals], counted)


def calibrate(
    model: ir.Model, corpus: Corpus, *, rounds: int = 8, samples: int = 300, seed: int = 0,
    late: Collection[str] = (),
) -> Calibration:
    """The model with calibrated probabilities, and notes on what happened.  Signals in
    ``late`` keep ``probability_start`` 0 (the constraints never let them start early)."""
    from mse.diagnostics import MseError

    counted = counted_signals(model, corpus)
    target = corpus_profile(corpus, counted)
    signals = [s.id for s in model.signals]
    duration = to_seconds(corpus.typical_duration)
    best: tuple[float, ir.Model, dict[str, float]] | None = None
    notes: list[str] = []
    current = with_late(model, late)
    steps = dict.fromkeys(signals, FIRST_STEP)
    previous: dict[str, float] = {}
    best_round = 0
    for round_number in progress.each(range(rounds + 1), "calibrate", unit="round"):
        try:
            sampled = sample_profile(current, duration, samples, seed, counted)
        except MseError as error:
            notes.append(f"calibration stopped: the learned set could not be sampled ({error})")
            break
        score = distance(target, sampled)
        errors = {s: target.rate[s] - sampled.rate[s] for s in signals}
        if best is None or score < best[0]:
            best, best_round = (score, current, errors), round_number
        worst = max(signals, key=lambda s: abs(errors[s]), default=None)
        notes.append(f"round {round_number}: distance {score:.3f}"
                     + (f", largest rate difference {abs(errors[worst]):.3f} ({worst})" if worst else ""))
        if (all(abs(errors[s]) <= tolerance(target.rate[s], samples) for s in signals) or round_number == rounds
                or round_number - best_round >= PATIENCE):
            break
        for signal in signals:
            if signal in previous and previous[signal] * errors[signal] < 0:
                steps[signal] = max(SMALLEST_STEP, steps[signal] / 2)
        previous = errors
        current = _adjusted(current, target, sampled, steps, late)
    if best is None:
        return Calibration(model, notes, {}, math.inf)
    return Calibration(best[1], notes, best[2], best[0])


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


#: A signal still this far from the corpus' rate after calibration, and beyond the
#: calibration's tolerance (:func:`tolerance`), is *stuck*: its probabilities cannot move it
#: (a learned rule forces or blocks it in the sampler).
STUCK_ERROR = 0.05
#: Sampling runs spent looking for rules to release, per stuck signal and in all.
RELEASE_TRIALS = 6
RELEASE_BUDGET = 12


def release_rules(
    calibration: Calibration, corpus: Corpus, *, samples: int = 300, seed: int = 0,
    trials: int = RELEASE_TRIALS, budget: int = RELEASE_BUDGET,
) -> tuple[ir.Model, list[tuple[str, str]]]:
    """Learned rules whose removal lets a stuck signal reach the corpus' rate, removed.

    For each stuck signal (largest difference first; a signal calibration brought within its
    tolerance is not stuck, whatever its difference), each learned constraint naming it is
    left out in turn and the set sampled (same seed and size as calibration): the one whose
    absence moves the signal furthest towards the corpus' rate (by at least
    :data:`STUCK_ERROR`; past it is fine: calibration then brings it back) is released.  Every rule held in every corpus
    sequence where it was tested, so leaving one out never rejects a sequence; it only stops
    the sampler from forcing or blocking a signal the corpus shows at another rate.  Returns
    the model without them and (constraint id, reason) pairs."""
    from mse.diagnostics import MseError

    counted = counted_signals(calibration.model, corpus)
    target = corpus_profile(corpus, counted)
    duration = to_seconds(corpus.typical_duration)
    current, errors = calibration.model, dict(calibration.errors)
    released: list[tuple[str, str]] = []

    def off(signal: str, found: Mapping[str, float]) -> float:  # relative above one start per sequence
        return abs(found[signal]) / max(1.0, target.rate[signal])

    stuck = sorted((s for s in errors if off(s, errors) > STUCK_ERROR
                    and abs(errors[s]) > tolerance(target.rate[s], samples)), key=lambda s: (-off(s, errors), s))
    for signal in stuck:
        if off(signal, errors) <= STUCK_ERROR or budget <= 0:
            continue
        naming = [c for c in current.constraints if signal in ir.mentioned_signals(c.expr)][:min(trials, budget)]
        best: tuple[float, str, ir.Model, dict[str, float]] | None = None
        for constraint in naming:
            budget -= 1
            trial = replace(current, constraints=tuple(c for c in current.constraints if c.id != constraint.id))
            try:
                sampled = sample_profile(trial, duration, samples, seed, counted)
            except MseError:
                continue
            trial_errors = {s: target.rate[s] - sampled.rate[s] for s in errors}
            # How far the signal moved towards the corpus' rate (or past it: its
            # probabilities can then bring it back), relative above one start per sequence.
            moved = (errors[signal] - trial_errors[signal]) * (1 if errors[signal] > 0 else -1)
            moved /= max(1.0, target.rate[signal])
            if moved >= STUCK_ERROR and (best is None or moved > best[0]):
                best = (moved, constraint.id, trial, trial_errors)
        if best is None:
            continue
        _, rule, current, new_errors = best
        want = target.rate[signal]
        what = "starts per timeline" if signal in counted else "of the timelines"
        released.append((rule, f"released: with it the default sampler shows {signal!r} in "
                               f"{want - errors[signal]:.2f} {what} whatever its probabilities, against "
                               f"{want:.2f} in the corpus; {want - new_errors[signal]:.2f} without it"))
        errors = new_errors
    return current, released

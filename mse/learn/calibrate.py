"""Calibrating the probability profiles by sampling the learned set (docs/learn.md).

The corpus shows each signal *through* the constraints (a smile that needs an exhale occurs
less often than its prior says), and the learned set's sampler applies the same constraints
again, with its own approximations (the walk loses a once-only signal whose constraints fail
at its candidacy).  So the raw estimates of :mod:`mse.learn.signals` are corrected by
simulation: sample the learned set at the corpus' typical duration with the default sampler,
compare each signal's rate (the fraction of sequences where it occurs; starts per sequence
for a repetitive signal present in nearly all of them, :func:`counted_signals`) and mean
relative start with the corpus, and adjust every signal's profile at once:

* its level by a power of the ratio of rates (``want / got``): a half step (its square root)
  at first, then half the step its measured response says reaches the corpus' rate
  (:func:`response`), halved after each change of direction (the signals interact through
  the constraints, and a signal's step must not oscillate), doubled when it never occurred;
  the level stays in what the profile can be (at most 1, at most 0.5 when
  ``probability_start`` is held at 0);
* its mean start by half the difference, unless the sampled start did not follow the last
  shift (:func:`_follows`).

A round far past the closest one (:data:`BACKTRACK`), or :data:`PATIENCE` rounds without a
closer one, start again from the closest round with every step halved.  Rounds stop when
every signal is within its tolerance (:func:`tolerance`: twice the sampling error of the
round, at least :data:`STOP_ERROR`), when the steps are at their smallest and still nothing
progresses, or after ``rounds`` adjustments (more while the last is the closest so far,
:data:`EXTRA_ROUNDS`); the round closest to the corpus (:func:`distance`) is kept.  Every
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
#: Rounds without a new closest one after which calibration starts again from the closest
#: with every step halved, and ends once the steps are at their smallest (the rates no longer
#: follow the probabilities: a rule forces or blocks a signal, see :func:`release_rules`).
PATIENCE = 3
#: Steps of the level, as powers of the ratio of rates: half at first (the square root of the
#: ratio), halved again at each change of direction, never below SMALLEST_STEP.  Full first
#: steps overshot where the sampler draws exactly (the rejection stage, docs/sampler.md):
#: random9's calibration moved away from the corpus from its first round (distance 4.0 → 7.1)
#: and ended with s14 at 0.08 against 0.31; half steps reach 1.3.
FIRST_STEP = 0.5
#: Once a signal's rate has answered a change of its level (:func:`response`), its step is
#: this share of the one that would reach the corpus' rate if the answer held: rates grow
#: less than in proportion to their level where constraints hold them back (random21's s15:
#: 0.44 → 0.75 for a level 2.7 times as high, a response of 0.53, so half steps of the ratio
#: took 8 rounds to cover what one secant step does).
SECANT_SHARE = 0.5
#: Responses below this are taken as this (a nearly stuck signal would otherwise jump to
#: its cap in one round), above the upper bound as that.
RESPONSE_RANGE = (0.3, 2.0)
#: The most a level is multiplied or divided by in one round (a response measured while
#: other signals moved too can be far from the signal's own).
LARGEST_FACTOR = 3.0
#: A shift of a profile's mean start too small to tell whether the sampled start followed
#: it, and the share of it the sampled start must follow for the next shift to be made.
SMALLEST_START_SHIFT = 0.02
SMALLEST_START_RESPONSE = 0.25
#: A change of level (of its logarithm) too small for the answer to be told from the noise.
SMALLEST_MOVE = 0.05
#: A signal whose difference changed sign has its steps halved, down to this share.
SMALLEST_DAMPING = 0.25
#: A round this many times as far from the corpus as the closest one so far is a step too
#: far: the next one starts again from the closest, with every step halved.
BACKTRACK = 2.0
#: Calibration goes on past ``rounds`` while the last round is the closest so far, up to
#: this many times ``rounds``.
EXTRA_ROUNDS = 2


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


def tolerance(rate: float, samples: int, fraction: bool = False) -> float:
    """How far a round's rate may be from the corpus' for the calibration to stop: twice the
    standard error of a rate measured on ``samples`` sequences (binomial below one start
    per sequence or for a ``fraction`` of the sequences, Poisson above), at least
    :data:`STOP_ERROR`."""
    spread = math.sqrt(rate * (1 - rate)) if rate < 1 or fraction else math.sqrt(rate)
    return max(STOP_ERROR, 2 * spread / math.sqrt(max(1, samples)))


#: The mean start difference that weighs as much in :func:`distance` as a rate at its
#: tolerance (the start matters less than whether the signal occurs at all).
START_SCALE = 0.1


def distance(target: Profile, sampled: Profile, samples: int) -> float:
    """Each signal's rate difference in units of its tolerance (:func:`tolerance`), squared
    and summed, plus its mean start difference in units of :data:`START_SCALE` (weighted by
    its rate, at most 1), squared; for a counted signal its presence's difference too
    (calibrated on its starts, it must still occur as often).  Squares: a round with one
    signal far off is worse than one with several a little off (the round trip asks every
    signal to be close); tolerances: a difference is measured against what sampling alone
    explains, not against the rate (relative differences let a rare signal 0.04 off outweigh a
    common one 0.15 off: random21 kept a round with s15 0.11 off for a rare s12)."""
    total = 0.0
    for signal, rate in target.rate.items():
        total += ((sampled.rate[signal] - rate) / tolerance(rate, samples)) ** 2
        total += ((sampled.mean_start[signal] - target.mean_start[signal]) / START_SCALE) ** 2 * min(1.0, rate)
        presence = target.presence[signal]
        if presence != rate:
            total += ((sampled.presence[signal] - presence) / tolerance(presence, samples, fraction=True)) ** 2
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
    the set cannot be sampled).  Where the sampler's rejection stage is too costly it makes
    each timeline with its chain stage (30 sweeps from a walk, docs/sampler.md "Chain"): the
    rates are then the chain's stationary law's, measured on a few long chains
    (:func:`mse.solve.chain.chain_samples`, one burn-in per chain rather than per timeline:
    random7's 300 timelines 75 s of CPU → about 4 s)."""
    from mse.solve.chain import chain_samples
    from mse.solve.protocol import SolveRequest, get_solver
    from mse.solve.rejection import Rejection, applies

    request = SolveRequest(duration=duration, seed=seed, count=samples)
    schedules: Sequence[Schedule]
    if applies(request) and not Rejection(model, request).budget.draws:
        schedules, _ = chain_samples(model, duration, samples, seed)
    else:
        schedules = get_solver("greedy").solve(model, request).schedules
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
    best: tuple[float, ir.Model, dict[str, float], Profile] | None = None
    notes: list[str] = []
    current = with_late(model, late)
    damping = dict.fromkeys(signals, 1.0)
    previous: dict[str, float] = {}
    last: tuple[ir.Model, Profile] | None = None
    best_round = 0
    limit = rounds
    round_number = 0
    with progress.bar(None, "calibrate", unit="round") as bar:
        while True:
            bar.update()
            try:
                sampled = sample_profile(current, duration, samples, seed, counted)
            except MseError as error:
                notes.append(f"calibration stopped: the learned set could not be sampled ({error})")
                break
            score = distance(target, sampled, samples)
            errors = {s: target.rate[s] - sampled.rate[s] for s in signals}
            if best is None or score < best[0]:
                best, best_round = (score, current, errors, sampled), round_number
            worst = max(signals, key=lambda s: abs(errors[s]), default=None)
            notes.append(f"round {round_number}: distance {score:.3f}"
                         + (f", largest rate difference {abs(errors[worst]):.3f} ({worst})" if worst else ""))
            # Still improving at the last round: a few more (a slow but steady approach, random21's
            # s15 0.44 -> 0.75 over 8 rounds, is not a stuck one).
            if round_number == limit and best_round == round_number and limit < EXTRA_ROUNDS * rounds:
                limit += 1
            if (all(abs(errors[s]) <= tolerance(target.rate[s], samples) for s in signals) or round_number >= limit
                    or (round_number - best_round >= PATIENCE and max(damping.values()) <= SMALLEST_DAMPING)):
                break
            if score > BACKTRACK * best[0] or round_number - best_round >= PATIENCE:
                # A step far past the closest round (a cluster of signals tied by rules flips
                # together: random16's s10, s12 and s16 went from 0.06, 0.55, 0.45 to 1, 1, 0),
                # or rounds without progress: back to the closest round, every step halved.
                _, current, errors, sampled = best
                damping = {s: max(SMALLEST_DAMPING, damping[s] / 2) for s in signals}
                last, previous = None, {}
            for signal in signals:
                if signal in previous and previous[signal] * errors[signal] < 0:
                    damping[signal] = max(SMALLEST_DAMPING, damping[signal] / 2)
            previous = errors
            current, last = _adjusted(current, target, sampled, damping, late, last), (current, sampled)
            round_number += 1
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


def _level(signal: ir.Signal) -> float:
    return (signal.probability_start + signal.probability_end) / 2


def response(level: float, rate: float, previous_level: float, previous_rate: float) -> float | None:
    """How the signal's rate answered its last change of level: the ratio of the changes of
    their logarithms (the secant of rate against level on log scales, :data:`RESPONSE_RANGE`),
    or None when the last change was too small to tell (or went the wrong way: another
    signal's change moved it more than its own)."""
    if min(level, rate, previous_level, previous_rate) <= 0:
        return None
    moved = math.log(level / previous_level)
    if abs(moved) < SMALLEST_MOVE:
        return None
    answer = math.log(rate / previous_rate) / moved
    if answer <= 0:
        return None
    return min(RESPONSE_RANGE[1], max(RESPONSE_RANGE[0], answer))


def _follows(signal: ir.Signal, before: ir.Signal, sampled: Profile, previous: Profile) -> bool:
    """Whether the signal's sampled mean start followed the last shift of its profile's mean
    (by at least :data:`SMALLEST_START_RESPONSE` of it, in its direction), or the shift was
    too small to tell.  Where the constraints set a signal's start, shifting its profile only
    moves its candidacies to where they are lost: random5's s17 (corpus mean start late)
    drifted from level 0.28 at mean 0.3 to a profile rising to the end while its rate fell
    from 0.89 to 0.62."""
    shift = profile_mean(signal.probability_start, signal.probability_end) - profile_mean(
        before.probability_start, before.probability_end)
    if abs(shift) < SMALLEST_START_SHIFT:
        return True
    moved = sampled.mean_start[signal.id] - previous.mean_start[signal.id]
    return moved / shift >= SMALLEST_START_RESPONSE


def _adjusted(model: ir.Model, target: Profile, sampled: Profile, damping: Mapping[str, float],
              late: Collection[str], last: tuple[ir.Model, Profile] | None) -> ir.Model:
    signals = []
    before = {s.id: s for s in last[0].signals} if last else {}
    for signal in model.signals:
        a, b = signal.probability_start, signal.probability_end
        level, mean = (a + b) / 2, profile_mean(a, b)
        want, got = target.rate[signal.id], sampled.rate[signal.id]
        if got > 0:
            answer = None
            if last is not None and signal.id in before:
                answer = response(level, got, _level(before[signal.id]), last[1].rate[signal.id])
            # A measured response: the step that would reach the corpus' rate if it held, a
            # little short of it; otherwise a half step (full steps overshot where the
            # sampler draws exactly, see FIRST_STEP).
            step = SECANT_SHARE / answer if answer is not None else FIRST_STEP
            factor = (want / got) ** (step * damping[signal.id])
            level = level * min(LARGEST_FACTOR, max(1 / LARGEST_FACTOR, factor))
            if last is None or signal.id not in before or _follows(signal, before[signal.id], sampled, last[1]):
                mean = mean + (target.mean_start[signal.id] - sampled.mean_start[signal.id]) / 2 * damping[signal.id]
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

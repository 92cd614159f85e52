"""Calibration of learned probabilities (mse/learn/calibrate.py, docs/learn.md "Calibration"):
what is compared, when a signal counts as stuck, and when released rules are kept; and the
learn → sample round trip on random sets where each of these went wrong (issue 32)."""

from __future__ import annotations

import dataclasses
import math
import random
from typing import Any

import pytest

import mse.sampling as sampling
from mse.diagnostics import Span
from mse.ir import model as ir
from mse.learn import LearnOptions, LearnResult
from mse.learn import calibrate as calibrate_module
from mse.learn.calibrate import Calibration, Profile, counted_signals, distance, release_rules, tolerance
from mse.learn.corpus import Corpus, CorpusSequence, SignalInfo

SPAN = Span("<test>")


def _corpus(present: dict[str, int], size: int = 100, starts: int = 2) -> Corpus:
    """``size`` sequences of 10 s; signal ``s`` starts ``starts`` times in the first
    ``present[s]`` of them."""
    sequences = []
    for number in range(size):
        occurrences = {s: tuple((1000 + 3000 * k, 2000 + 3000 * k) for k in range(starts))
                       for s, count in present.items() if number < count}
        sequences.append(CorpusSequence(f"q{number}", 10_000, occurrences, SPAN))
    return Corpus(tuple(sequences), {s: SignalInfo(s, "face", f"lex={s}") for s in present})


def _model(signals: list[str], constraints: tuple[ir.Constraint, ...] = ()) -> ir.Model:
    return ir.Model("t", tuple(ir.Signal(id=s, modality="face", lexeme=f"lex={s}", min_duration=1.0,
                                         max_duration=1.0, probability_start=0.5, probability_end=0.5,
                                         repetitivity=1) for s in signals), constraints, ())


def test_a_repetitive_signal_is_calibrated_on_presence_where_its_absence_is_measurable() -> None:
    """random7's s6, in 95 % of 300 sequences and counted on its starts, came back in 82 % with
    the right number of starts: its absences are measured, so its presence is calibrated."""
    corpus = _corpus({"often": 95, "always": 99})
    assert counted_signals(_model(["often", "always"]), corpus) == {"always"}


def test_the_distance_counts_a_counted_signals_presence() -> None:
    target = Profile({"a": 2.0}, {"a": 0.5}, {"a": 1.0})
    assert distance(target, Profile({"a": 2.0}, {"a": 0.5}, {"a": 1.0}), 300) == 0
    assert distance(target, Profile({"a": 2.0}, {"a": 0.5}, {"a": 0.8}), 300) == pytest.approx((0.2 / 0.02) ** 2)


def test_the_distance_weighs_differences_by_their_tolerance_not_by_the_rate() -> None:
    """random21 kept a round with the common s15 0.11 off (corpus 0.75) for one where a rare
    signal was 0.04 off: relative differences (0.04 / 0.05) outweighed it (0.11 / 0.75).  In
    units of the sampling tolerance the common signal's difference counts more."""
    target = Profile({"common": 0.75, "rare": 0.05}, {"common": 0.5, "rare": 0.5}, {"common": 0.75, "rare": 0.05})
    common_off = Profile({"common": 0.64, "rare": 0.05}, target.mean_start, {"common": 0.64, "rare": 0.05})
    rare_off = Profile({"common": 0.75, "rare": 0.01}, target.mean_start, {"common": 0.75, "rare": 0.01})
    assert distance(target, common_off, 300) > distance(target, rare_off, 300)


def test_a_steady_slow_response_is_followed_by_a_secant_step() -> None:
    """A rate that grew 0.44 -> 0.75 for a level 2.7 times as high answers with about half
    the change of level (on log scales); a response that went the wrong way, or a move too
    small to tell, gives none (a half step then)."""
    assert calibrate_module.response(0.35, 0.75, 0.128, 0.44) == pytest.approx(0.53, abs=0.01)
    assert calibrate_module.response(0.35, 0.40, 0.128, 0.44) is None
    assert calibrate_module.response(0.130, 0.75, 0.128, 0.44) is None
    assert calibrate_module.response(0.35, 0.441, 0.128, 0.44) == calibrate_module.RESPONSE_RANGE[0]


def test_a_mean_start_the_sampler_does_not_follow_is_not_shifted_again() -> None:
    """random5's s17: its profile's mean start moved later round after round (the corpus' was
    later than the sampled one) while the sampled start stayed put and its rate fell from 0.89
    to 0.62 (candidacies moved to where they were lost).  A shift the sampled start did not
    follow is not made again; one it followed is."""
    before = ir.Signal(id="a", modality="face", lexeme="lex=a", min_duration=1.0, max_duration=1.0,
                       probability_start=0.5, probability_end=0.1, repetitivity=1)
    after = ir.Signal(id="a", modality="face", lexeme="lex=a", min_duration=1.0, max_duration=1.0,
                      probability_start=0.3, probability_end=0.3, repetitivity=1)
    then = Profile({"a": 0.8}, {"a": 0.40}, {"a": 0.8})
    stayed = Profile({"a": 0.7}, {"a": 0.41}, {"a": 0.7})
    followed = Profile({"a": 0.8}, {"a": 0.45}, {"a": 0.8})
    assert not calibrate_module._follows(after, before, stayed, then)
    assert calibrate_module._follows(after, before, followed, then)
    assert calibrate_module._follows(before, before, stayed, then)  # no shift: nothing to tell


def test_calibration_follows_a_slow_response_next_to_a_jump(monkeypatch: pytest.MonkeyPatch) -> None:
    """Signals whose rate grows as the square root of their level (held back by constraints)
    reach the corpus' rate in 5 adjustments (from 0.17 and 0.13 of it), one of them just
    below a level past which its rate jumps to 1 (a cluster flipping)."""
    corpus = _corpus({"slow": 75, "cliff": 40}, size=100, starts=1)

    def fake(model: ir.Model, duration: float, samples: int, seed: int, counted: Any = ()) -> Profile:
        level = {s.id: (s.probability_start + s.probability_end) / 2 for s in model.signals}
        rate = {"slow": min(1.0, 0.8 * math.sqrt(level["slow"])),
                "cliff": 1.0 if level["cliff"] > 0.5 else 0.6 * math.sqrt(level["cliff"])}
        return Profile(rate, {"slow": 0.2, "cliff": 0.2}, rate)

    monkeypatch.setattr(calibrate_module, "sample_profile", fake)
    start = _model(["slow", "cliff"])
    start = ir.Model("t", tuple(dataclasses.replace(s, probability_start=0.05, probability_end=0.05, repetitivity=0)
                                for s in start.signals), (), ())
    result = calibrate_module.calibrate(start, corpus, samples=300)
    assert abs(result.errors["slow"]) <= tolerance(0.75, 300), result.notes
    assert abs(result.errors["cliff"]) <= tolerance(0.40, 300), result.notes
    assert len(result.notes) <= 6


def test_a_signal_within_calibrations_tolerance_is_not_stuck(monkeypatch: pytest.MonkeyPatch) -> None:
    """random14's s3 (mandatory, 1.35 starts per sequence) ended calibration 0.13 off, within
    its tolerance (0.134) but above STUCK_ERROR relative: its ``exists(s3)`` was released and
    s3 came back in 86 % of the timelines.  Within the tolerance no rule is tried."""
    corpus = _corpus({"a": 300}, size=300)
    model = _model(["a"], (ir.Constraint("a_occurs", ir.Exists("a")),))
    error = 0.9 * tolerance(2.0, 300)
    assert error / 2.0 > calibrate_module.STUCK_ERROR

    def no_sampling(*args: Any, **kwargs: Any) -> Profile:
        raise AssertionError("a signal within the tolerance was tried as stuck")

    monkeypatch.setattr(calibrate_module, "sample_profile", no_sampling)
    loosened, released = release_rules(Calibration(model, [], {"a": error}, 1.0), corpus, samples=300)
    assert (loosened, released) == (model, [])


def test_released_rules_are_kept_when_calibration_without_them_is_no_closer(monkeypatch: pytest.MonkeyPatch) -> None:
    import importlib

    learn_module = importlib.import_module("mse.learn.learn")

    model = _model(["a"], (ir.Constraint("a_occurs", ir.Exists("a")),))
    loosened = ir.Model("t", model.signals, (), ())
    scores = iter([1.0, 2.0])

    def calibrate(start: ir.Model, corpus: Corpus, **kwargs: Any) -> Calibration:
        return Calibration(start, [f"round 0 of {len(start.constraints)}"], {}, next(scores))

    def release(calibration: Calibration, corpus: Corpus, **kwargs: Any) -> tuple[ir.Model, list[tuple[str, str]]]:
        return loosened, [("a_occurs", "released: ...")]

    monkeypatch.setattr(calibrate_module, "calibrate", calibrate)
    monkeypatch.setattr(calibrate_module, "release_rules", release)
    kept, notes, released = learn_module._calibrated(model, _corpus({"a": 10}), LearnOptions(), late=(),
                                                     release=True)
    assert kept is model and released == []
    assert "released rules kept" in notes[-1]
    scores = iter([2.0, 1.0])
    kept, _, released = learn_module._calibrated(model, _corpus({"a": 10}), LearnOptions(), late=(), release=True)
    assert kept is loosened and released == [("a_occurs", "released: ...")]


def learned_from_random_set(seed: int) -> tuple[list[Any], LearnResult]:
    """The round trip of bench/evaluation/learn_roundtrip.py for one set (its row there): the
    corpus (seeds ``seed..``), the set learned from it (calibrated on unrelated seeds)."""
    from bench.evaluation.learn_roundtrip import LEARN_SEEDS, corpus_of
    from bench.generators.corpus import random_model
    from mse.learn import learn_corpus

    truth = random_model(seed, 18, random.Random(seed).randint(9, 36), name=f"random{seed}")
    corpus = list(sampling.iter_timelines(truth, 10.0, seed=seed, count=300))
    options = LearnOptions(name=f"random{seed}", confidence=1.0, seed=seed + LEARN_SEEDS)
    return corpus, learn_corpus(corpus_of(corpus), options)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [
    7,
    14,
    21,
])
def test_random_sets_sample_back_at_the_corpus_rates(seed: int) -> None:
    """random7 (s6 0.95 -> 0.82 while calibration measured the walk; its set now chains, and
    calibration measures the chain's law on long chains) and random14 (s3 1.00 -> 0.86: its
    ``exists`` released while within tolerance) sample back within 0.1 of the corpus."""
    from bench.evaluation.learn_roundtrip import BACK_SEEDS, occurrence_rates

    corpus, result = learned_from_random_set(seed)
    back = list(sampling.iter_timelines(result.model, 10.0, seed=seed + BACK_SEEDS, count=1000))
    before, after = occurrence_rates(corpus), occurrence_rates(back)
    off = {s: (before.get(s, 0.0), after.get(s, 0.0)) for s in set(before) | set(after)
           if abs(before.get(s, 0.0) - after.get(s, 0.0)) > 0.1}
    assert off == {}, (off, result.calibration)
    if seed == 14:
        assert "s3_occurs" in {c.id for c in result.model.constraints}

"""HSMM adaptation internals: forward-backward occupancies against brute force, soft vs
hard statistics, CMLLR priors centred on a parent transform, regression classes."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from mse.motion.hsmm.adapt import (
    AffineTransform,
    GaussianStats,
    adapt_units,
    auto_blocks,
    blocks_for,
    class_blocks,
    estimate_cmllr,
    regression_class,
)
from mse.motion.hsmm.cmllr import estimate_refinement
from mse.motion.hsmm.model import Instance, UnitModel, duration_logpdf, frame_loglik
from mse.motion.hsmm.occupancy import occupancy
from mse.motion.hsmm.stats import output_stats, soft_stats


def _unit(rng: np.random.Generator, states: int = 3, width: int = 2) -> UnitModel:
    return UnitModel(
        rng.normal(size=(states, width)) * 2,
        rng.uniform(0.5, 2.0, size=(states, width)),
        rng.uniform(2.0, 4.0, size=states),
        rng.uniform(1.0, 3.0, size=states),
    )


def test_occupancy_matches_enumeration_of_every_state_split() -> None:
    rng = np.random.default_rng(11)
    unit = _unit(rng)
    frames = rng.normal(size=(9, 2))
    loglik = frame_loglik(frames, unit.means, unit.variances)
    scores, splits = [], []
    for cuts in itertools.combinations(range(1, 9), 2):
        bounds = (0, *cuts, 9)
        score = sum(
            loglik[bounds[s] : bounds[s + 1], s].sum()
            + duration_logpdf(
                np.array(float(bounds[s + 1] - bounds[s])),
                float(unit.duration_means[s]),
                float(unit.duration_variances[s]),
            )
            for s in range(3)
        )
        scores.append(float(score))
        splits.append(bounds)
    total = float(np.logaddexp.reduce(scores))
    gamma = np.zeros((9, 3))
    mean = np.zeros(3)
    for score, bounds in zip(scores, splits, strict=True):
        weight = np.exp(score - total)
        for s in range(3):
            gamma[bounds[s] : bounds[s + 1], s] += weight
            mean[s] += weight * (bounds[s + 1] - bounds[s])
    found = occupancy(frames, unit)
    assert found is not None
    assert abs(found.loglik - total) < 1e-9
    assert np.allclose(found.gamma, gamma, atol=1e-12)
    assert np.allclose(found.gamma.sum(axis=1), 1.0)
    assert np.allclose(found.duration_mean, mean, atol=1e-12)
    assert occupancy(frames[:2], unit) is None  # fewer frames than states


def test_soft_statistics_equal_hard_ones_when_states_are_unambiguous() -> None:
    unit = UnitModel(
        np.array([[0.0], [5.0], [10.0]]),
        np.full((3, 1), 0.05),
        np.array([4.0, 6.0, 3.0]),
        np.array([2.0, 2.0, 2.0]),
    )
    frames = np.concatenate([np.full(4, 0.0), np.full(6, 5.0), np.full(3, 10.0)])[:, None]
    instance = Instance("inner-a", "x", frames, (0, 4, 10, 13))
    units = {"inner-a": unit}
    hard = output_stats([instance], units)
    soft, durations = soft_stats([instance], units, units)
    for key, stats in hard.items():
        assert abs(soft[key].count - stats.count) < 1e-6
        assert np.allclose(soft[key].total, stats.total, atol=1e-5)
    assert np.allclose(durations["inner-a"].total, [4.0, 6.0, 3.0], atol=1e-6)


def test_cmllr_prior_pulls_towards_its_centre() -> None:
    rng = np.random.default_rng(12)
    centre = AffineTransform(np.eye(4) + 0.1 * rng.normal(size=(4, 4)), rng.normal(size=4))
    stats = []
    for _ in range(3):
        frames = rng.normal(size=(5, 4))
        stats.append(GaussianStats(5.0, frames.sum(0), frames.T @ frames, np.zeros(4), np.ones(4)))
    pinned = estimate_cmllr(stats, [np.arange(4)], prior=1e9, centre=centre)
    assert np.allclose(pinned.matrix, centre.matrix, atol=1e-5)
    assert np.allclose(pinned.bias, centre.bias, atol=1e-5)


def test_regression_classes_and_block_rule() -> None:
    assert [regression_class(u) for u in ("first-a", "inner-b", "last-a", "whole")] == [
        "a",
        "b",
        "a",
        "whole",
    ]
    assert auto_blocks(66, 60) == "joint" and auto_blocks(66, 134) == "stream"
    # Data drawn from the model shifted by +1: every unit moves by +1, seen (first-a,
    # inner-b) or not (inner-a, through the transform of its leg's class).
    rng = np.random.default_rng(13)
    units = {}
    for name in ("first-a", "inner-a", "inner-b"):
        unit = _unit(rng, 3, 3)
        units[name] = UnitModel(unit.means, unit.variances, np.full(3, 100.0), np.full(3, 9.0))
    instances = []
    for name in ("first-a", "inner-b"):
        unit = units[name]
        noise = rng.normal(size=(300, 3)) * np.sqrt(np.repeat(unit.variances, 100, axis=0))
        frames = np.repeat(unit.means, 100, axis=0) + 1.0 + noise
        instances.append(Instance(name, "x", frames, (0, 100, 200, 300)))
    adapted, output, _ = adapt_units(
        units, instances, np.full(3, 1e-4), [np.array([i]) for i in range(3)], use_map=False
    )
    for name in units:
        shift = adapted[name].means - units[name].means
        assert np.allclose(shift, 1.0, atol=0.2), (name, shift)
    assert np.all(np.isfinite(output.matrix))


def test_duration_transform_cannot_collapse_states() -> None:
    """One adaptation take whose alignment gave [63, 1, 1, 1, 24] frames (the issue's bow):
    every state keeps a duration within a factor 2 of the data's tempo."""
    from mse.motion.hsmm.adapt import DURATION_SCALE_RANGE, estimate_duration_scale
    from mse.motion.hsmm.stats import GaussianStats

    observed = np.array([63.0, 1.0, 1.0, 1.0, 24.0])
    means = np.full(5, 18.0)
    stats = [GaussianStats(1.0, observed, np.outer(observed, observed), means, np.full(5, 9.0))]
    transform = estimate_duration_scale(stats)
    adapted, _ = transform.model_space(means[None, :], np.full((1, 5), 9.0))
    tempo = observed.sum() / means.sum()
    assert np.all(adapted[0] >= means * tempo / DURATION_SCALE_RANGE - 1e-9)
    assert np.all(adapted[0] <= means * tempo * DURATION_SCALE_RANGE + 1e-9)
    assert adapted[0].sum() == pytest.approx(observed.sum(), rel=0.35)


def test_one_shot_actions_get_states_for_their_length() -> None:
    from mse.motion.hsmm.api import MAX_STATES, Options, unit_states

    assert unit_states(True, [18, 20], Options()) == 5  # steps keep 5
    assert unit_states(False, [138], Options()) == round(138 / 4)  # a 4.6 s bow
    assert unit_states(False, [12], Options()) == 5
    assert unit_states(False, [2000], Options()) == MAX_STATES


def test_wave_classes_are_contexts_and_small_ones_get_joint_static_blocks() -> None:
    names = ("first-a", "inner-b", "last-a", "whole")
    assert [regression_class(u, by_context=True) for u in names] == ["first", "inner", "last", "whole"]
    stream = blocks_for(6, "stream")  # two joints: 6 statics, blocks of 6 → 14 frames
    assert [len(b) for b in class_blocks(stream, 6, 14.0)[0]] == [6, 6, 6]
    assert class_blocks(stream, 6, 14.0)[1] == 14.0
    assert class_blocks(stream, 6, 10.0) == ([], 14.0)  # steps: no transform
    small, weight = class_blocks(stream, 6, 10.0, small=True)
    assert weight == 8.0 and [b.tolist() for b in small[:3]] == [[0, 1, 2], [3, 4, 5], [6, 7, 8]]
    assert len(small) == 6  # two joints × three streams
    assert class_blocks(stream, 6, 7.0, small=True)[0] == []


def test_a_short_rise_gets_its_own_transform_by_context() -> None:
    # A wave's swings and fall fit the model; its 12-frame rise is 2 higher in the statics.
    # By leg, the rise's class (a) is too small for stream blocks and keeps the global
    # transform, which the swings dominate; by context it gets per-joint static blocks.
    rng = np.random.default_rng(5)
    units = {}
    for name in ("first-a", "inner-a", "inner-b", "last-b"):
        unit = _unit(rng, 3, 18)
        units[name] = UnitModel(unit.means, unit.variances, np.full(3, 4.0), np.full(3, 1.0))
    instances = []
    for name, length, shift in (("first-a", 12, 2.0), ("inner-b", 60, 0.0), ("last-b", 12, 0.0)):
        unit = units[name]
        cut = length // 3
        means = np.repeat(unit.means, cut, axis=0)
        frames = means + rng.normal(size=means.shape) * np.sqrt(np.repeat(unit.variances, cut, axis=0))
        frames[:, :6] += shift
        instances.append(Instance(name, "x", frames, (0, cut, 2 * cut, 3 * cut)))
    blocks = blocks_for(6, "stream")
    floor = np.full(18, 1e-6)
    rises = {}
    for by_context in (False, True):
        adapted, _, _ = adapt_units(units, instances, floor, blocks, use_map=False, by_context=by_context)
        rises[by_context] = float(np.mean(adapted["first-a"].means[:, :6] - units["first-a"].means[:, :6]))
        swing = adapted["inner-b"].means[:, :6] - units["inner-b"].means[:, :6]
        assert abs(float(swing.mean())) < 0.5, (by_context, swing)
    assert rises[True] > 1.5 and rises[False] < 1.2, rises


def test_a_refinement_on_data_its_parent_already_fits_is_the_parent() -> None:
    rng = np.random.default_rng(3)
    means, variances = rng.normal(size=(4, 9)), rng.uniform(0.5, 1.0, size=(4, 9))
    parent = AffineTransform(np.eye(9) + 0.1 * rng.normal(size=(9, 9)), rng.normal(size=9))
    stats = []
    for mean, variance in zip(means, variances, strict=True):
        model_frames = mean + rng.normal(size=(400, 9)) * np.sqrt(variance)
        frames = np.linalg.solve(parent.matrix, (model_frames - parent.bias).T).T  # x with A x + b ~ model
        stats.append(GaussianStats(400.0, frames.sum(axis=0), frames.T @ frames, mean, variance))
    refined = estimate_refinement(stats, blocks_for(3, "joint"), 8.0, parent)  # one joint
    assert np.allclose(refined.matrix, parent.matrix, atol=0.1)
    assert np.allclose(refined.bias, parent.bias, atol=0.1)


def test_wave_contexts_keep_their_own_tempo() -> None:
    # The rise (first) takes as long as the model expects; the swings (inner) five times
    # as long. By leg, the swings' tempo stretches the rise; by context it keeps its own.
    units = {
        name: UnitModel(np.zeros((3, 3)), np.ones((3, 3)), np.full(3, 4.0), np.full(3, 1.0))
        for name in ("first-a", "inner-b", "inner-a", "last-a")
    }
    instances = [
        Instance("first-a", "x", np.zeros((12, 3)), (0, 4, 8, 12)),
        Instance("inner-b", "x", np.zeros((60, 3)), (0, 20, 40, 60)),
        Instance("inner-a", "x", np.zeros((60, 3)), (0, 20, 40, 60)),
    ]
    blocks = [np.array([i]) for i in range(3)]
    rise = {}
    for by_context in (False, True):
        adapted, _, _ = adapt_units(units, instances, np.full(3, 1e-4), blocks, use_map=False, by_context=by_context)
        rise[by_context] = float(adapted["first-a"].duration_means.sum())
    assert rise[True] < 16.0 < 30.0 < rise[False], rise

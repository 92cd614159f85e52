"""HSMM method, array level: windows, MLPG, exponential maps, CMLLR/MAP, durations, GV."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from mse.motion.base.kinematics import euler_to_matrix
from mse.motion.hsmm.adapt import (
    AffineTransform,
    GaussianStats,
    blocks_for,
    estimate_cmllr,
    map_update,
    transform_units,
)
from mse.motion.hsmm.features import (
    continuous_expmaps,
    expmap_from_matrix,
    matrix_from_expmap,
    observations,
    window_matrix,
)
from mse.motion.hsmm.mlpg import generate_with_gv, global_variance, mlpg, mlpg_dense
from mse.motion.hsmm.model import DURATION_VARIANCE_FLOOR, Instance, UnitModel, align, frame_loglik
from mse.motion.hsmm.synth import state_durations


def test_observations_equal_window_matrix_times_statics() -> None:
    rng = np.random.default_rng(1)
    statics = rng.normal(size=(17, 4))
    stacked = window_matrix(17) @ statics  # (3T, D), stream-major rows
    expected = np.concatenate([stacked[s * 17 : (s + 1) * 17] for s in range(3)], axis=1)
    assert np.allclose(observations(statics), expected, atol=1e-12)
    # Interior frames follow HTS's windows exactly ([-0.5, 0, 0.5] and [1, -2, 1]).
    t = 8
    delta = observations(statics)[t, 4:8]
    assert np.allclose(delta, 0.5 * (statics[t + 1] - statics[t - 1]))
    accel = observations(statics)[t, 8:12]
    assert np.allclose(accel, statics[t + 1] - 2 * statics[t] + statics[t - 1])


@pytest.mark.parametrize("frames", [1, 2, 5, 40, 120])
def test_mlpg_banded_matches_dense_solve(frames: int) -> None:
    rng = np.random.default_rng(frames)
    means = rng.normal(size=(frames, 9))
    variances = rng.uniform(0.05, 3.0, size=(frames, 9))
    assert np.max(np.abs(mlpg(means, variances) - mlpg_dense(means, variances))) < 1e-9


def test_mlpg_recovers_a_consistent_trajectory() -> None:
    rng = np.random.default_rng(2)
    statics = np.cumsum(rng.normal(size=(60, 3)), axis=0)
    generated = mlpg(observations(statics), np.full((60, 9), 0.3))
    assert np.max(np.abs(generated - statics)) < 1e-9


def test_expmap_matrix_round_trips() -> None:
    rng = np.random.default_rng(3)
    axes = rng.normal(size=(500, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    angles = rng.uniform(0.0, np.pi - 1e-6, size=500)
    expmaps = axes * angles[:, None]
    expmaps[:3] = np.array([[0.0, 0.0, 0.0], [1e-10, 0.0, 0.0], [0.0, 0.0, 1e-7]])
    matrices = matrix_from_expmap(expmaps)
    assert np.allclose(matrices @ np.swapaxes(matrices, 1, 2), np.eye(3), atol=1e-12)
    assert np.allclose(np.linalg.det(matrices), 1.0)
    assert np.max(np.abs(expmap_from_matrix(matrices) - expmaps)) < 1e-9
    # Matrix -> exp map -> matrix, from Euler angles of every size (through ±180°).
    euler = rng.uniform(-180.0, 180.0, size=(500, 3))
    rotations = euler_to_matrix(euler, "ZXY")
    assert np.max(np.abs(matrix_from_expmap(expmap_from_matrix(rotations)) - rotations)) < 1e-9


def test_continuous_expmaps_do_not_jump_across_pi() -> None:
    angles = np.linspace(2.8, 3.5, 50)  # through π about a fixed axis
    axis = np.array([0.0, 0.6, 0.8])
    matrices = matrix_from_expmap(axis * angles[:, None])
    expmaps = continuous_expmaps(matrices[:, None])[:, 0]
    assert np.max(np.linalg.norm(np.diff(expmaps, axis=0), axis=1)) < 0.05
    assert np.allclose(matrix_from_expmap(expmaps), matrices, atol=1e-9)


def _unit(rng: np.random.Generator, states: int = 3, width: int = 6) -> UnitModel:
    return UnitModel(
        rng.normal(size=(states, width)),
        rng.uniform(0.5, 2.0, size=(states, width)),
        rng.uniform(2.0, 6.0, size=states),
        rng.uniform(1.0, 3.0, size=states),
    )


def test_identity_adaptation_leaves_the_model_unchanged() -> None:
    rng = np.random.default_rng(4)
    units = {"inner-a": _unit(rng), "inner-b": _unit(rng)}
    same = transform_units(units, AffineTransform.identity(6), AffineTransform.identity(3))
    mapped = map_update(units, [], floor=np.full(6, 1e-6))
    for adapted in (same, mapped):
        for name, unit in units.items():
            for field in ("means", "variances", "duration_means", "duration_variances"):
                assert np.allclose(getattr(adapted[name], field), getattr(unit, field))


def test_cmllr_recovers_a_known_feature_transform() -> None:
    rng = np.random.default_rng(5)
    width, gaussians = 6, 8
    means = rng.normal(size=(gaussians, width)) * 3
    variances = rng.uniform(0.2, 1.0, size=(gaussians, width))
    true_matrix = np.eye(width) + 0.2 * rng.normal(size=(width, width))
    true_bias = rng.normal(size=width)
    stats = []
    for m in range(gaussians):
        canonical = means[m] + rng.normal(size=(4000, width)) * np.sqrt(variances[m])
        observed = (canonical - true_bias) @ np.linalg.inv(true_matrix).T
        stats.append(
            GaussianStats(4000.0, observed.sum(0), observed.T @ observed, means[m], variances[m])
        )
    found = estimate_cmllr(stats, [np.arange(width)], prior=0.0, iterations=20)
    assert np.allclose(found.matrix, true_matrix, atol=0.05)
    assert np.allclose(found.bias, true_bias, atol=0.1)
    blocks = blocks_for(6, "joint")
    assert [b.tolist() for b in blocks[:2]] == [[0, 1, 2], [3, 4, 5]]
    assert len(blocks_for(6, "stream")) == 3


def test_state_durations_sum_exactly_and_stay_positive() -> None:
    rng = np.random.default_rng(6)
    units = [_unit(rng, states=5) for _ in range(4)]
    for frames in (20, 21, 57, 150, 400):
        durations = state_durations(units, frames)
        assert int(durations.sum()) == frames
        assert durations.min() >= 1
    seeded = state_durations(units, 90, np.random.default_rng(0))
    assert int(seeded.sum()) == 90
    with pytest.raises(ValueError):
        state_durations(units, 10)


def test_a_seed_draws_only_durations_the_clips_vary() -> None:
    # States at the duration variance floor (seen once) keep their means whatever the seed;
    # states whose durations vary are drawn.
    zeros = np.zeros((4, 3))
    floor = UnitModel(zeros, np.ones((4, 3)), np.array([4.0, 6.0, 4.0, 6.0]), np.full(4, DURATION_VARIANCE_FLOOR))
    varied = replace(floor, duration_variances=np.full(4, 9.0))
    plain = state_durations([floor], 20)
    assert [state_durations([floor], 20, np.random.default_rng(seed)).tolist() for seed in range(5)] == [
        plain.tolist()
    ] * 5
    drawn = {tuple(state_durations([varied], 20, np.random.default_rng(seed)).tolist()) for seed in range(5)}
    assert len(drawn) > 1


def test_hsmm_alignment_finds_the_true_state_boundaries() -> None:
    rng = np.random.default_rng(7)
    unit = UnitModel(
        np.array([[0.0], [5.0], [10.0]]),
        np.full((3, 1), 0.2),
        np.array([4.0, 6.0, 3.0]),
        np.array([2.0, 2.0, 2.0]),
    )
    frames = np.concatenate([np.full(4, 0.0), np.full(7, 5.0), np.full(3, 10.0)])
    frames = (frames + 0.1 * rng.normal(size=frames.size))[:, None]
    bounds, score = align(frame_loglik(frames, unit.means, unit.variances), unit)
    assert bounds == (0, 4, 11, 14)
    assert np.isfinite(score)
    assert Instance("inner-a", "x", frames, bounds).durations().tolist() == [4.0, 7.0, 3.0]


def test_global_variance_compensation_restores_the_target_variance() -> None:
    frames, dims = 90, 4
    means = np.zeros((frames, 3 * dims))
    means[:, :dims] = np.sin(np.linspace(0, 6, frames))[:, None] * np.arange(1, dims + 1)
    variances = np.concatenate(
        [np.full((frames, dims), 4.0), np.full((frames, 2 * dims), 0.01)], axis=1
    )
    plain = mlpg(means, variances)
    target = 1.5 * global_variance(plain)
    compensated = generate_with_gv(means, variances, target, (0.05 * target) ** 2)
    ratio = global_variance(compensated) / target
    assert np.all((ratio > 0.9) & (ratio < 1.1)), ratio
    assert np.all(np.isfinite(compensated))


def test_swing_twist_root_features_round_trip_and_unwrap_a_full_spin() -> None:
    from mse.motion.hsmm.prep import twist_features, twist_matrices

    rng = np.random.default_rng(3)
    up = np.array([0.1, -0.2, 0.97])
    up /= np.linalg.norm(up)
    yaw = np.linspace(0.0, 2.4 * np.pi, 60)  # more than a full turn
    tilt = np.tile(rng.normal(size=3) * 0.2, (60, 1)) + rng.normal(size=(60, 3)) * 0.01
    tilt -= (tilt @ up)[:, None] * up[None, :]  # a swing: no component about the vertical
    rotations = matrix_from_expmap(yaw[:, None] * up[None, :]) @ matrix_from_expmap(tilt)
    features = twist_features(rotations, up)
    assert np.allclose(features @ up, yaw, atol=1e-9)  # a continuous scalar past 2π
    assert np.allclose(twist_matrices(features, up), rotations, atol=1e-12)
    # the exponential map of the same spin jumps near 2π; these features move smoothly
    step = 2.4 * np.pi / 59
    assert np.max(np.linalg.norm(np.diff(features, axis=0), axis=1)) < 1.5 * step
    assert np.max(np.linalg.norm(np.diff(continuous_expmaps(rotations[:, None])[:, 0], axis=0), axis=1)) > 3 * step

"""HSMM adaptation: regression blocks of different sizes, the root joint's own block; the
alignment lattice with bounded runs (long one-shot clips with many states)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from mse.motion.hsmm import model as model_module
from mse.motion.hsmm.adapt import GaussianStats, blocks_for, estimate_cmllr
from mse.motion.hsmm.model import UnitModel, align, duration_logpdf, frame_loglik, max_run
from mse.motion.hsmm.occupancy import occupancy


def _stats(seed: int, width: int, gaussians: int = 6) -> list[GaussianStats]:
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(gaussians):
        mean = rng.normal(size=width) * 2
        variance = rng.uniform(0.3, 1.0, size=width)
        mixing = np.eye(width) + 0.3 * rng.normal(size=(width, width))
        data = rng.normal(size=(50, width)) @ mixing.T + rng.normal(size=width)
        out.append(GaussianStats(50.0, data.sum(0), data.T @ data, mean, variance))
    return out


def test_the_static_stream_block_can_leave_the_root_joint_in_its_own_block() -> None:
    blocks = blocks_for(9, "stream", root=3)
    assert sorted(len(b) for b in blocks) == [3, 6, 9, 9]
    covered = np.sort(np.concatenate(blocks))
    assert covered.tolist() == list(range(27))  # every column, once
    assert [b.tolist() for b in blocks if len(b) == 3] == [[3, 4, 5]]
    assert [b.tolist() for b in blocks if len(b) == 6] == [[0, 1, 2, 6, 7, 8]]


def test_blocks_of_different_sizes_are_estimated_each_on_its_own() -> None:
    # Block-diagonal CMLLR rows depend only on their own block: estimating [0..5] and
    # [6..8] together must give what each gives alone.
    stats = _stats(11, 9)
    mixed = estimate_cmllr(stats, [np.arange(6), np.arange(6, 9)], prior=1.0)
    big = estimate_cmllr(stats, [np.arange(6)], prior=1.0)
    small = estimate_cmllr(stats, [np.arange(6, 9)], prior=1.0)
    assert np.allclose(mixed.matrix[:6, :6], big.matrix[:6, :6])
    assert np.allclose(mixed.matrix[6:, 6:], small.matrix[6:, 6:])
    assert np.allclose(mixed.bias, np.concatenate([big.bias[:6], small.bias[6:]]))
    assert np.allclose(mixed.matrix[:6, 6:], 0.0) and np.allclose(mixed.matrix[6:, :6], 0.0)


def _enumerate(loglik: np.ndarray, unit: UnitModel, longest: int) -> tuple[list[float], list[tuple[int, ...]]]:
    """Every split of the frames into the unit's states with runs of at most ``longest``."""
    length, states = loglik.shape
    scores, splits = [], []
    for cuts in itertools.combinations(range(1, length), states - 1):
        bounds = (0, *cuts, length)
        if max(b - a for a, b in itertools.pairwise(bounds)) > longest:
            continue
        score = sum(
            loglik[bounds[s] : bounds[s + 1], s].sum()
            + duration_logpdf(
                np.array(float(bounds[s + 1] - bounds[s])),
                float(unit.duration_means[s]),
                float(unit.duration_variances[s]),
            )
            for s in range(states)
        )
        scores.append(float(score))
        splits.append(bounds)
    return scores, splits


def test_runs_are_bounded_only_for_long_instances_with_many_states() -> None:
    assert max_run(20, 5) == 20  # a walk step: the whole lattice
    assert max_run(138, 34) == 138  # a bow: the whole lattice
    assert max_run(1901, 475) == 257  # the dataset 1 dance: 64 times its frames per state


@pytest.mark.parametrize("span", [1, 2])
def test_bounded_alignment_and_occupancy_match_enumeration(monkeypatch: pytest.MonkeyPatch, span: int) -> None:
    # 12 frames, 4 states: runs of at most 3 (RUN_SPAN 1) or 6 frames (RUN_SPAN 2).
    monkeypatch.setattr(model_module, "RUN_SPAN", span)
    rng = np.random.default_rng(21 + span)
    states, length = 4, 12
    unit = UnitModel(
        rng.normal(size=(states, 2)) * 2,
        rng.uniform(0.5, 2.0, size=(states, 2)),
        rng.uniform(2.0, 4.0, size=states),
        rng.uniform(1.0, 3.0, size=states),
    )
    frames = rng.normal(size=(length, 2)) * 2
    loglik = frame_loglik(frames, unit.means, unit.variances)
    longest = max_run(length, states)
    assert longest == 3 * span
    scores, splits = _enumerate(loglik, unit, longest)
    bounds, score = align(loglik, unit)
    assert bounds == splits[int(np.argmax(scores))]
    assert score == pytest.approx(max(scores), abs=1e-9)
    total = float(np.logaddexp.reduce(scores))
    gamma = np.zeros((length, states))
    mean = np.zeros(states)
    for value, split in zip(scores, splits, strict=True):
        weight = np.exp(value - total)
        for s in range(states):
            gamma[split[s] : split[s + 1], s] += weight
            mean[s] += weight * (split[s + 1] - split[s])
    found = occupancy(frames, unit)
    assert found is not None
    assert found.loglik == pytest.approx(total, abs=1e-9)
    assert np.allclose(found.gamma, gamma, atol=1e-12)
    assert np.allclose(found.duration_mean, mean, atol=1e-12)

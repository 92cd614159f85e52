"""HSMM training details: occupancy-weighted (soft) re-estimation, the style's own GV spread."""

from __future__ import annotations

import numpy as np

from mse.motion.hsmm.model import Instance, UnitModel, train_units, uniform_bounds
from mse.motion.hsmm.occupancy import occupancy
from mse.motion.hsmm.soft_training import estimate_units_soft, train_units_soft


def _instances(rng: np.random.Generator, count: int = 6) -> list[Instance]:
    """Noisy three-state ramps with varying state lengths."""
    out = []
    for _ in range(count):
        lengths = rng.integers(3, 8, size=3)
        frames = np.concatenate([np.full(n, 4.0 * s) for s, n in enumerate(lengths)])
        frames = frames[:, None] + rng.normal(scale=0.7, size=(frames.size, 2))
        out.append(Instance("inner-a", "x", frames, uniform_bounds(frames.shape[0], 3)))
    return out


def _forward_total(instances: list[Instance], units: dict[str, UnitModel]) -> float:
    total = 0.0
    for instance in instances:
        found = occupancy(instance.observations, units[instance.unit])
        assert found is not None
        total += found.loglik
    return total


def test_soft_reestimation_equals_hard_when_states_are_unambiguous() -> None:
    frames = np.concatenate([np.full(4, 0.0), np.full(6, 5.0), np.full(3, 10.0)])[:, None]
    instance = Instance("inner-a", "x", frames, (0, 4, 10, 13))
    unit = UnitModel(
        np.array([[0.0], [5.0], [10.0]]), np.full((3, 1), 0.05), np.array([4.0, 6.0, 3.0]), np.full(3, 2.0)
    )
    soft = estimate_units_soft([instance], {"inner-a": unit}, floor=np.full(1, 1e-3))["inner-a"]
    assert np.allclose(soft.means[:, 0], [0.0, 5.0, 10.0], atol=1e-4)
    assert np.allclose(soft.duration_means, [4.0, 6.0, 3.0], atol=1e-3)


def test_soft_iterations_do_not_lower_the_likelihood() -> None:
    rng = np.random.default_rng(21)
    instances = _instances(rng)
    floor = np.full(2, 1e-3)
    hard, aligned = train_units(instances, 3, iterations=4, floor=floor)
    soft = train_units_soft(instances, 3, iterations=4, floor=floor, soft_iterations=3)
    assert _forward_total(aligned, soft) >= _forward_total(aligned, hard) - 1e-6
    assert np.all(np.isfinite(soft["inner-a"].means)) and np.all(soft["inner-a"].variances >= floor)

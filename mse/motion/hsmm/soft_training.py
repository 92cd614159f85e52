"""Occupancy-weighted (Baum-Welch style) re-estimation of HSMM units.

Segmental k-means (:func:`mse.motion.hsmm.model.train_units`) gives every frame to one
state.  HTS trains with the full explicit-duration forward-backward instead: each frame
counts for every state in proportion to its posterior, and each state's duration
Gaussian comes from the posterior duration moments.  Training starts from the
segmental-k-means model and then runs these soft iterations; adaptive training (SAT)
uses the same statistics for its per-style transforms.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from mse.motion.hsmm.features import FloatArray
from mse.motion.hsmm.model import (
    DURATION_VARIANCE_FLOOR,
    Instance,
    Transform,
    UnitModel,
    identity_transform,
    train_units,
)
from mse.motion.hsmm.occupancy import posteriors


def estimate_units_soft(
    instances: Sequence[Instance],
    units: Mapping[str, UnitModel],
    floor: FloatArray,
    transform: Transform = identity_transform,
    duration_transform: Transform = identity_transform,
) -> dict[str, UnitModel]:
    """One soft re-estimation of every unit from its instances' posteriors under ``units``."""
    sums: dict[str, list[FloatArray]] = {}
    durations: dict[str, list[tuple[FloatArray, FloatArray]]] = {}
    for instance in instances:
        unit = units[instance.unit]
        obs = transform(instance.style, instance.observations)
        gamma, mean, square = posteriors(obs, unit, instance)
        acc = sums.setdefault(
            instance.unit,
            [np.zeros(unit.states), np.zeros(unit.means.shape), np.zeros(unit.means.shape)],
        )
        acc[0] += gamma.sum(axis=0)
        acc[1] += gamma.T @ obs
        acc[2] += gamma.T @ obs**2
        moved = duration_transform(instance.style, mean[None, :])[0]
        durations.setdefault(instance.unit, []).append((moved, np.maximum(square - mean**2, 0.0)))
    out: dict[str, UnitModel] = {}
    for name, (counts, totals, squares) in sorted(sums.items()):
        safe = np.maximum(counts, 1e-6)[:, None]
        means = totals / safe
        variances = np.maximum(squares / safe - means**2, floor[None, :])
        moved = np.array([d for d, _ in durations[name]])
        within = np.array([w for _, w in durations[name]])
        out[name] = UnitModel(
            means=means,
            variances=variances,
            duration_means=np.maximum(moved.mean(axis=0), 1.0),
            duration_variances=np.maximum(
                moved.var(axis=0) + within.mean(axis=0), DURATION_VARIANCE_FLOOR
            ),
        )
    return out


def train_units_soft(
    instances: Sequence[Instance],
    states: int,
    iterations: int,
    floor: FloatArray,
    soft_iterations: int = 2,
) -> dict[str, UnitModel]:
    """Segmental k-means, then ``soft_iterations`` occupancy-weighted re-estimations."""
    units, aligned = train_units(instances, states, iterations, floor)
    for _ in range(soft_iterations):
        units = estimate_units_soft(aligned, units, floor)
    return units

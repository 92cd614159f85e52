"""Sufficient statistics of adaptation data per Gaussian: hard (one Viterbi alignment) or
soft (occupancy-weighted, forward-backward, as HTS gathers them for CMLLR and MAP)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from mse.motion.hsmm.features import FloatArray
from mse.motion.hsmm.model import Instance, UnitModel, realign
from mse.motion.hsmm.occupancy import posteriors


@dataclass(frozen=True, eq=False)
class GaussianStats:
    """Sufficient statistics of the data one Gaussian holds, with its parameters."""

    count: float
    total: FloatArray  # (n,)
    scatter: FloatArray  # (n, n)
    mean: FloatArray  # (n,)
    variance: FloatArray  # (n,)


def output_stats(
    instances: Sequence[Instance], units: Mapping[str, UnitModel]
) -> dict[tuple[str, int], GaussianStats]:
    """Per (unit, state) statistics of the aligned frames."""
    acc: dict[tuple[str, int], list[FloatArray]] = {}
    for instance in instances:
        for s in range(len(instance.bounds) - 1):
            chunk = instance.observations[instance.bounds[s] : instance.bounds[s + 1]]
            if chunk.shape[0]:
                acc.setdefault((instance.unit, s), []).append(chunk)
    out = {}
    for (unit, s), chunks in sorted(acc.items()):
        frames = np.concatenate(chunks)
        model = units[unit]
        out[unit, s] = GaussianStats(
            float(frames.shape[0]),
            frames.sum(axis=0),
            frames.T @ frames,
            model.means[s],
            model.variances[s],
        )
    return out


def duration_stats(
    instances: Sequence[Instance], units: Mapping[str, UnitModel]
) -> dict[str, GaussianStats]:
    """Per unit statistics of the state-duration vectors."""
    acc: dict[str, list[FloatArray]] = {}
    for instance in instances:
        acc.setdefault(instance.unit, []).append(instance.durations())
    out = {}
    for unit, rows in sorted(acc.items()):
        d = np.asarray(rows)
        model = units[unit]
        out[unit] = GaussianStats(
            float(d.shape[0]),
            d.sum(axis=0),
            d.T @ d,
            model.duration_means,
            model.duration_variances,
        )
    return out


def soft_stats(
    instances: Sequence[Instance],
    units: Mapping[str, UnitModel],
    posterior: Mapping[str, UnitModel],
) -> tuple[dict[tuple[str, int], GaussianStats], dict[str, GaussianStats]]:
    """Occupancy-weighted output and duration statistics (HTS's adaptation statistics).

    Occupancies come from the ``posterior`` model (the current adapted one); the Gaussians
    recorded with the statistics are those of ``units`` (the transform's source).  An
    instance shorter than the unit's states keeps its hard alignment.
    """
    width = next(iter(units.values())).means.shape[1]
    states = next(iter(units.values())).states
    acc: dict[tuple[str, int], list[FloatArray]] = {}
    dacc: dict[str, list[FloatArray]] = {}
    for instance in instances:
        obs = instance.observations
        gamma, mean, square = posteriors(obs, posterior[instance.unit], instance)
        for s in range(states):
            weight = gamma[:, s]
            key = (instance.unit, s)
            if key not in acc:
                acc[key] = [np.zeros(1), np.zeros(width), np.zeros((width, width))]
            acc[key][0] += weight.sum()
            acc[key][1] += weight @ obs
            acc[key][2] += (obs * weight[:, None]).T @ obs
        # Duration scatter: posterior second moments on the diagonal, states independent
        # off it (the run posteriors of different states are not stored jointly).
        scatter = np.outer(mean, mean)
        scatter[np.diag_indices(states)] = square
        if instance.unit not in dacc:
            dacc[instance.unit] = [np.zeros(1), np.zeros(states), np.zeros((states, states))]
        dacc[instance.unit][0] += 1.0
        dacc[instance.unit][1] += mean
        dacc[instance.unit][2] += scatter
    out = {
        (unit, s): GaussianStats(
            float(c[0]), t, sc, units[unit].means[s], units[unit].variances[s]
        )
        for (unit, s), (c, t, sc) in sorted(acc.items())
        if float(c[0]) > 1e-6
    }
    dout = {
        unit: GaussianStats(
            float(c[0]), t, sc, units[unit].duration_means, units[unit].duration_variances
        )
        for unit, (c, t, sc) in sorted(dacc.items())
    }
    return out, dout


def collect_stats(
    instances: Sequence[Instance],
    units: Mapping[str, UnitModel],
    posterior: Mapping[str, UnitModel],
    soft: bool,
) -> tuple[dict[tuple[str, int], GaussianStats], dict[str, GaussianStats]]:
    """Soft statistics, or hard ones from a Viterbi alignment under ``posterior``."""
    if soft:
        return soft_stats(instances, units, posterior)
    aligned = realign(instances, posterior)
    return output_stats(aligned, units), duration_stats(aligned, units)

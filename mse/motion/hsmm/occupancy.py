"""Soft (forward-backward) state occupancies of HSMM unit instances (paper §5.1.3).

HTS estimates adaptation transforms and MAP updates from occupancy-weighted statistics, not
from one Viterbi alignment.  A unit instance of ``L`` frames is a left-to-right chain of
``S`` states, each a contiguous run, so its lattice is the set of runs ``[b, e)`` per
state.  The explicit-duration forward-backward recursion over that lattice gives the
posterior probability of every run, hence of every frame being in every state (``gamma``)
and the posterior moments of every state's duration.  Everything is in log space; the cost
is O(S·L²) like the Viterbi search in :func:`mse.motion.hsmm.model.align`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mse.motion.hsmm.features import FloatArray
from mse.motion.hsmm.model import Instance, UnitModel, duration_logpdf, frame_loglik


@dataclass(frozen=True, eq=False)
class Occupancy:
    """Posterior state occupation of one unit instance."""

    gamma: FloatArray  # (L, S) probability that frame t is in state s
    duration_mean: FloatArray  # (S,) posterior mean duration of each state (frames)
    duration_square: FloatArray  # (S,) posterior mean of the squared duration
    loglik: float  # log P(observations, durations | unit)


def _logsumexp(values: FloatArray, axis: int) -> FloatArray:
    peak = np.max(values, axis=axis, keepdims=True)
    safe = np.where(np.isfinite(peak), peak, 0.0)
    with np.errstate(divide="ignore"):  # log 0 = -inf: an impossible run
        result: FloatArray = np.squeeze(safe, axis=axis) + np.log(
            np.sum(np.exp(values - safe), axis=axis)
        )
    return result


def occupancy(observations: FloatArray, unit: UnitModel) -> Occupancy | None:
    """Forward-backward over the runs of the unit's states; None if ``L < S``."""
    loglik = frame_loglik(observations, unit.means, unit.variances)
    length, states = loglik.shape
    if length < states:
        return None
    cumulative = np.vstack([np.zeros((1, states)), np.cumsum(loglik, axis=0)])
    span = (np.arange(length + 1)[None, :] - np.arange(length + 1)[:, None]).astype(np.float64)
    valid = span >= 1
    # run[s][b, e]: log density of frames [b, e) in state s, with the duration e - b.
    runs = []
    for s in range(states):
        duration = duration_logpdf(
            np.maximum(span, 1.0), float(unit.duration_means[s]), float(unit.duration_variances[s])
        )
        output = cumulative[None, :, s] - cumulative[:, None, s]
        runs.append(np.where(valid, output + duration, -np.inf))
    forward = np.full((states + 1, length + 1), -np.inf)  # forward[s, e]: s states end at e
    forward[0, 0] = 0.0
    for s in range(states):
        forward[s + 1] = _logsumexp(forward[s][:, None] + runs[s], axis=0)
    backward = np.full((states + 1, length + 1), -np.inf)  # backward[s, b]: state s starts at b
    backward[states, length] = 0.0
    for s in range(states - 1, -1, -1):
        backward[s] = _logsumexp(runs[s] + backward[s + 1][None, :], axis=1)
    total = float(forward[states, length])
    if not np.isfinite(total):
        return None
    gamma = np.zeros((length, states))
    mean = np.zeros(states)
    square = np.zeros(states)
    upper = np.triu(np.ones((length + 1, length + 1), dtype=bool), k=1)
    for s in range(states):
        posterior = np.exp(forward[s][:, None] + runs[s] + backward[s + 1][None, :] - total)
        mean[s] = float(np.sum(posterior * span))
        square[s] = float(np.sum(posterior * span**2))
        # Frame t is in the run [b, e) when b <= t < e: sum over b <= t, then over e > t.
        by_start = np.cumsum(posterior, axis=0)
        gamma[:, s] = np.sum(np.where(upper, by_start, 0.0), axis=1)[:length]
    return Occupancy(gamma, mean, square, total)


def posteriors(
    observations: FloatArray, unit: UnitModel, instance: Instance
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Frame posteriors (L, S) and per-state duration moments (mean, mean square) of an
    instance; its hard alignment when the lattice is empty (fewer frames than states)."""
    occ = occupancy(observations, unit)
    if occ is not None:
        return occ.gamma, occ.duration_mean, occ.duration_square
    gamma = np.zeros((observations.shape[0], unit.states))
    for s in range(unit.states):
        gamma[instance.bounds[s] : instance.bounds[s + 1], s] = 1.0
    mean = instance.durations()
    return gamma, mean, mean**2

"""Soft (forward-backward) state occupancies of HSMM unit instances (paper §5.1.3).

HTS estimates adaptation transforms and MAP updates from occupancy-weighted statistics, not
from one Viterbi alignment.  A unit instance of ``L`` frames is a left-to-right chain of
``S`` states, each a contiguous run, so its lattice is the set of runs ``[b, e)`` per
state.  The explicit-duration forward-backward recursion over that lattice gives the
posterior probability of every run, hence of every frame being in every state (``gamma``)
and the posterior moments of every state's duration.  Everything is in log space; the cost
is O(S·L·R), runs of at most R frames, like the Viterbi search in
:func:`mse.motion.hsmm.model.align`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mse.motion.hsmm.features import FloatArray
from mse.motion.hsmm.model import Instance, UnitModel, frame_loglik, max_run, run_scores


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
    """Forward-backward over the runs of the unit's states (at most
    :func:`mse.motion.hsmm.model.max_run` frames each); None if ``L < S``."""
    loglik = frame_loglik(observations, unit.means, unit.variances)
    length, states = loglik.shape
    if length < states:
        return None
    cumulative = np.vstack([np.zeros((1, states)), np.cumsum(loglik, axis=0)])
    longest = max_run(length, states)
    lengths = np.arange(1, longest + 1)
    starts = np.arange(length + 1)[:, None]
    ends = np.minimum(starts + lengths[None, :], length)  # (L+1, R); clipped where -inf
    # The run ending at e with length r + 1 starts at e - r - 1: gathering by end.
    ending_start = starts - lengths[None, :]  # (L+1 ends, R)
    ending_valid = ending_start >= 0
    ending_start = np.maximum(ending_start, 0)
    ending_column = np.broadcast_to(lengths[None, :] - 1, ending_start.shape)

    def by_end(values: FloatArray, empty: float) -> FloatArray:
        """(L+1 starts, R) → (L+1 ends, R)."""
        result: FloatArray = np.where(ending_valid, values[ending_start, ending_column], empty)
        return result

    # The run scores of a state, (L+1 starts, R lengths), are recomputed in each pass rather
    # than kept for every state: S of them would be the O(S·L²) memory this bound removes.
    forward = np.full((states + 1, length + 1), -np.inf)  # forward[s, e]: s states end at e
    forward[0, 0] = 0.0
    for s in range(states):
        scored = forward[s][:, None] + run_scores(cumulative, unit, s, longest)
        forward[s + 1] = _logsumexp(by_end(scored, -np.inf), axis=1)
    backward = np.full((states + 1, length + 1), -np.inf)  # backward[s, b]: state s starts at b
    backward[states, length] = 0.0
    for s in range(states - 1, -1, -1):
        backward[s] = _logsumexp(run_scores(cumulative, unit, s, longest) + backward[s + 1][ends], axis=1)
    total = float(forward[states, length])
    if not np.isfinite(total):
        return None
    gamma = np.zeros((length, states))
    mean = np.zeros(states)
    square = np.zeros(states)
    for s in range(states):
        scored = forward[s][:, None] + run_scores(cumulative, unit, s, longest) + backward[s + 1][ends]
        posterior = np.exp(scored - total)  # (L+1 starts, R)
        mean[s] = float(np.sum(posterior * lengths[None, :]))
        square[s] = float(np.sum(posterior * lengths[None, :] ** 2))
        # Frame t is in the run [b, e) when b <= t < e: runs started by t minus runs ended by t.
        started = np.cumsum(posterior.sum(axis=1))
        ended = np.cumsum(by_end(posterior, 0.0).sum(axis=1))
        gamma[:, s] = (started - ended)[:length]
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

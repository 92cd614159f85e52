"""How the body is carried, per state: the flight phases of runs and dashes.

The HSMM's features are joint rotations; where the body goes follows from the feet
(:func:`mse.motion.base.contacts.root_track`: the lowest foot point is pinned). Runs and
dashes have flight phases, when no foot is on the floor: pinning alone carried the body only
by the stance foot's stride, and Bandai dataset 1 runs and dashes travelled at about half
their real speed (1 of 15 dashes and 5 of 15 runs within the real spread).

So, as the LMA + HMM method does through its states, each state of a cyclic action's units
holds the mean of :func:`mse.motion.base.contacts.support` over the training frames it is
aligned to: the root's horizontal velocity (in the clips' aligned frame, facing +Z), the
lowest foot point's lift and the support in [0, 1]. Adaptation re-estimates them from the
style's takes with a MAP prior of one visit of the state (as the output Gaussians). At
synthesis the per-state values follow the state durations (the velocity scaled by the
unit's natural over its played length), are low-passed like the other trajectories and
passed to ``root_track``: while a frame is unsupported the root keeps the velocity instead
of following a swinging foot, and rises by the lift.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from mse.motion.base.bvh import Motion
from mse.motion.base.contacts import support
from mse.motion.base.filters import zero_phase_lowpass
from mse.motion.hsmm.features import FloatArray, yaw_matrix
from mse.motion.hsmm.model import Instance, UnitModel, align, frame_loglik
from mse.motion.hsmm.prep import Template, alignment_yaws

#: columns: root velocity X, Z (file units per second, aligned frame), lift, support
CARRIED_COLUMNS = 4
#: a state whose frames are supported this often or more counts as fully supported: real
#: walks never leave the floor, but the lowest point of a rolling foot rises over the floor
#: band (:data:`mse.motion.base.contacts.FLOOR_BAND`) now and then, and states supported
#: 95-97 % of the time let a generated walk's stance foot slide by the rest
STANCE_SHARE = 0.9


def clip_carried(motion: Motion, template: Template) -> FloatArray:
    """(T, 4) :func:`support` of a real clip, its velocity turned as the features are
    (the clip's mean heading along +Z, or turning locomotion's path heading frame by frame:
    :func:`mse.motion.hsmm.prep.alignment_yaws`)."""
    values = support(motion)
    turn = yaw_matrix(-alignment_yaws(motion.positions(), template))  # (T, 3, 3)
    velocity_x, velocity_z = values[:, 0].copy(), values[:, 1].copy()
    values[:, 0] = turn[:, 0, 0] * velocity_x + turn[:, 0, 2] * velocity_z
    values[:, 1] = turn[:, 2, 0] * velocity_x + turn[:, 2, 2] * velocity_z
    return values


def carried_profiles(
    units: Mapping[str, UnitModel],
    instances: Sequence[Instance],
    prior: Mapping[str, FloatArray] | None = None,
) -> dict[str, FloatArray]:
    """Per unit, the (S, 4) mean carried values of the frames each state is aligned to (HSMM
    Viterbi under ``units``). With ``prior`` (e.g. the average model's profiles), each state's
    mean is a MAP estimate whose prior is worth one visit of the state (its mean duration);
    units without data keep their prior."""
    sums: dict[str, FloatArray] = {}
    counts: dict[str, FloatArray] = {}
    for instance in instances:
        if instance.carried is None or instance.unit not in units:
            continue
        unit = units[instance.unit]
        bounds, score = align(frame_loglik(instance.observations, unit.means, unit.variances), unit)
        if score == float("-inf"):
            bounds = instance.bounds
        total = sums.setdefault(instance.unit, np.zeros((unit.states, CARRIED_COLUMNS)))
        count = counts.setdefault(instance.unit, np.zeros(unit.states))
        for s in range(unit.states):
            chunk = instance.carried[bounds[s] : bounds[s + 1]]
            total[s] += chunk.sum(axis=0)
            count[s] += chunk.shape[0]
    profiles: dict[str, FloatArray] = dict(prior or {})
    for name, total in sums.items():
        count = counts[name][:, None]
        if prior is not None and name in prior:
            weight = units[name].duration_means[:, None]
            profiles[name] = (weight * prior[name] + total) / (weight + count)
            continue
        unit_mean = total.sum(axis=0) / max(float(count.sum()), 1.0)
        profiles[name] = np.where(count > 0, total / np.maximum(count, 1.0), unit_mean[None, :])
    return profiles


def carried_track(
    units: Sequence[UnitModel], profiles: Sequence[FloatArray | None], durations: np.ndarray
) -> FloatArray | None:
    """(T, 4) carried values of a generated sequence (``durations``: frames per state of all
    units in order), or None when a unit has no profile. Velocities are scaled by each unit's
    natural over played length: a step played slower covers the same stride."""
    if not units or any(p is None for p in profiles):
        return None
    rows = []
    start = 0
    for unit, profile in zip(units, profiles, strict=True):
        assert profile is not None
        own = durations[start : start + unit.states]
        start += unit.states
        values = np.repeat(profile, own, axis=0)
        values[values[:, 3] >= STANCE_SHARE, 3] = 1.0
        values[:, :2] *= float(unit.duration_means.sum()) / max(float(own.sum()), 1.0)
        rows.append(values)
    result: FloatArray = np.concatenate(rows)
    return result


def smooth_carried(carried: FloatArray, frame_time: float, cutoff_hz: float) -> FloatArray:
    """``carried`` low-passed (the per-state values step at state boundaries), with the lift
    kept non-negative and the support within [0, 1] (the filter overshoots a little)."""
    smoothed = zero_phase_lowpass(carried, frame_time, cutoff_hz)
    smoothed[:, 2] = np.maximum(smoothed[:, 2], 0.0)
    smoothed[:, 3] = np.clip(smoothed[:, 3], 0.0, 1.0)
    return smoothed

"""The stride of generated locomotion: the state means' swing restored to the neighbours'.

A walk or a run drawn through 12 state means per cycle, ramped between the runs' midpoints
and low-passed, swings its legs less far than the clips the means come from: every state
averages the frames around an extreme of the swing with frames nearer its middle. The
stride shortens, and pinned stance feet carry the body less far per step (Bandai dataset 1,
childish run: the real clip re-grounded 161 cm/s, the neighbour's own Viterbi path drawn
through the 12 means 138; the desired path generated 135.5, limit 137).

:func:`stride_gains` measures that loss on the neighbours themselves: each neighbour's own
Viterbi path drawn through the means (the same ramps and low-pass as the generated path)
against its real rotations, joint by joint (the spread of the joint's rotation vectors
about the neighbours' mean, its three components pooled). :func:`restored_means` widens the
state means about that mean by the joint's gain. The generated path is linear in the means
(ramps, then a zero-phase low-pass that keeps constants), so widening the means widens the
path — and the continued cycles of :func:`mse.motion.lma_hmm.modulated.path_for`, drawn from
the same means — by the same gain. It is the global variance of HMM speech synthesis
(Toda & Tokuda 2007), measured on the neighbours rather than learned.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

import numpy as np
import numpy.typing as npt

from mse.motion.base.bodyparts import limb_groups
from mse.motion.base.bvh import Skeleton
from mse.motion.base.contacts import runs
from mse.motion.base.kinematics import FloatArray
from mse.motion.lma_hmm.hmm import Encoding, smooth, state_path
from mse.motion.lma_hmm.modulated import cutoff

#: a joint's gain is at most this (a state mean that lost more than half of a joint's swing
#: is a decoding problem, not an averaging one)
MAX_GAIN = 2.0
#: joints whose real rotations spread less than this (radians, RMS about their mean) keep
#: their means: their spread is capture noise, and widening it only adds jitter
MIN_SPREAD = 0.02


def stride_gains(
    means: FloatArray,
    rotations: Sequence[FloatArray],
    labels: Sequence[npt.NDArray[np.int_]],
    frame_time: float,
    cutoff_hz: Sequence[float],
    joints: int,
) -> FloatArray:
    """(joints,) per rotated joint: the RMS spread of the neighbours' real rotations about
    their mean over that of their own state paths drawn through ``means`` (low-passed at
    each neighbour's ``cutoff_hz``), in [1, :data:`MAX_GAIN`]; 1 where either is too small
    to tell."""
    columns = 3 * joints
    real = [np.asarray(r[:, :columns], dtype=np.float64) for r in rotations]
    if not real or len(real) != len(labels) or len(cutoff_hz) != len(labels):
        return np.ones(joints)
    centre = np.vstack(real).mean(axis=0)
    drawn = [
        smooth(state_path(means[:, :columns], lab), frame_time, hz) for lab, hz in zip(labels, cutoff_hz, strict=True)
    ]
    real_spread = _spread(np.vstack(real) - centre, joints)
    drawn_spread = _spread(np.vstack(drawn) - centre, joints)
    gains = np.ones(joints)
    usable = (real_spread >= MIN_SPREAD) & (drawn_spread > 1e-9)
    gains[usable] = np.clip(real_spread[usable] / drawn_spread[usable], 1.0, MAX_GAIN)
    return gains


def _spread(deviations: FloatArray, joints: int) -> FloatArray:
    """(joints,) RMS length of each joint's rotation-vector deviation."""
    squared = np.sum(deviations.reshape(len(deviations), joints, 3) ** 2, axis=2)
    result: FloatArray = np.sqrt(np.mean(squared, axis=0))
    return result


def restored_means(
    means: FloatArray, rotations: Sequence[FloatArray], gains: FloatArray, selected: Sequence[int] | None = None
) -> FloatArray:
    """``means`` with each rotated joint's columns widened by its gain about the neighbours'
    mean rotation (``selected``: indices of the joints to widen, default all); the columns
    after the rotations (how the body is carried) are kept."""
    joints = len(gains)
    columns = 3 * joints
    centre = np.vstack([r[:, :columns] for r in rotations]).mean(axis=0)
    chosen = np.zeros(joints, dtype=bool)
    chosen[list(range(joints)) if selected is None else list(selected)] = True
    per_column = np.repeat(np.where(chosen, gains, 1.0), 3)
    out = means.copy()
    out[:, :columns] = centre + per_column * (means[:, :columns] - centre)
    return out


#: the neighbours travel when their root's mean velocity (faced as the desired path, pooled)
#: is at least this many leg lengths per second. Bandai real clips: walks, runs and dashes of
#: every direction 0.40-4.7, every other action under 0.045 (a childish bow's or an active
#: byebye's body sways at 0.1-0.18 without going anywhere: the median speed alone counted
#: them as moving)
TRAVEL_LEG_LENGTHS_PER_S = 0.2


def travels(carried: Sequence[FloatArray], leg_length: float) -> bool:
    """Whether the root velocities of ``carried`` (columns 0-1, :func:`~mse.motion.base.contacts.support`)
    go somewhere: their pooled mean at least :data:`TRAVEL_LEG_LENGTHS_PER_S` leg lengths per second."""
    if leg_length <= 0 or not carried:
        return False
    velocity = np.vstack([c[:, :2] for c in carried]).mean(axis=0)
    return bool(np.linalg.norm(velocity) >= TRAVEL_LEG_LENGTHS_PER_S * leg_length)




#: which joints :func:`restore_stride` widens: "legs" (thighs and shins), "all" (every
#: rotated joint), "off"
Stride = Literal["off", "legs", "all"]


def swing_joints(skeleton: Skeleton) -> list[int]:
    """The thigh and shin of each leg: the hip joints (legs whose parent is not a leg) and
    their children. The feet are left out: their spread is mostly the roll of the foot on
    the floor, and widening it moved the points the stance pins (dataset 1 feminine
    walk-back, feet widened too: -29.5 -> -23.7 cm/s, jerk 12,200 -> 17,400; thighs and
    shins only: -60.0, 5,000)."""
    legs = set(limb_groups(skeleton)["legs"])
    hips = [j for j in sorted(legs) if skeleton.parents[j] not in legs]
    return hips + [c for h in hips for c in skeleton.children(h) if c in legs]


def restore_stride(
    means: FloatArray,
    rotations: Sequence[FloatArray],
    labels: Sequence[npt.NDArray[np.int_]],
    frame_time: float,
    base_hz: float,
    encoding: Encoding,
    which: Stride,
) -> FloatArray:
    """``means`` widened by :func:`stride_gains` measured on the neighbours (``rotations``
    and their own Viterbi ``labels``, drawn with the low-pass of
    :func:`~mse.motion.lma_hmm.modulated.cutoff` from ``base_hz``); ``which``: "legs"
    (:func:`swing_joints`) or "all" of the encoding's rotated joints.

    For any number of neighbours. With one, the means average that clip's own frames (Bandai
    dataset 1: one clip per style of runs, dashes, backwards and sideways walks); with two,
    two takes (its forward walks: the musical walk, left alone, went 2.7 cm/s; widened, 121).
    It was at most two: with dataset 2's eight, the faster stride jolted the pinned root
    (Samadani, dataset 2 walks, elderly -> normal jerk 18,400 -> 24,400 cm/s^3, limit 20,900),
    before the changes of stance foot were smoothed (base.contacts). Left alone, eight takes'
    means walked short: dataset 2 walks at 1x, active 125 cm/s (its takes 135-158),
    exhausted 91 (93-123), youthful 117 (125-141); the same walks bent along a 20 deg/s arc
    (bench/evaluation/turning.py) 134, 96, 123. Widened: 141, 110, 125 straight; jerk at most
    0.8x its limit, fidelity 21 / 21 at 1x, 2x, 3x; Samadani folds 1, 2 unchanged (41 of 42
    recognised, fidelity 42 / 42)."""
    if which == "off" or not labels:
        return means
    hz = [cutoff(base_hz, len(lab), 1 + int(np.count_nonzero(np.diff(lab))), frame_time) for lab in labels]
    rotated = encoding.rotated
    gains = stride_gains(means, rotations, labels, frame_time, hz, len(rotated))
    swing = set(swing_joints(encoding.skeleton))
    selected = None if which == "all" else [k for k, joint in enumerate(rotated) if joint in swing]
    widened = restored_means(means, rotations, gains, selected)
    return restored_flight(widened, means, rotations, labels, frame_time, hz, 3 * len(rotated))


def restored_flight(
    widened: FloatArray,
    means: FloatArray,
    rotations: Sequence[FloatArray],
    labels: Sequence[npt.NDArray[np.int_]],
    frame_time: float,
    cutoff_hz: Sequence[float],
    columns: int,
) -> FloatArray:
    """``widened`` with the lift and the support (the carried columns ``columns + 2`` and
    ``+ 3``, :func:`~mse.motion.base.contacts.support`) of running neighbours
    (:func:`~mse.motion.base.contacts.runs`) widened like the rotations, each by its own gain measured on the
    neighbours (:func:`stride_gains` on one column), the support kept within [0, 1] and the
    lift above the floor. Averaged over a state, a flight phase was partly supported and
    hardly lifted: the root kept the neighbours' velocity while a foot still touched the
    floor (dataset 1 musical run: foot slip 31.9 cm/s, limit 26.4; restored, 23.4)."""
    if widened.shape[1] < columns + 4 or len(rotations) != len(labels) or not rotations:
        return widened
    support = np.concatenate([r[:, columns + 3] for r in rotations])
    if not runs(support):
        return widened
    out = widened.copy()
    for column in (columns + 2, columns + 3):
        real = np.concatenate([r[:, column] for r in rotations])
        drawn = np.concatenate(
            [
                smooth(state_path(means[:, column : column + 1], lab), frame_time, hz)[:, 0]
                for lab, hz in zip(labels, cutoff_hz, strict=True)
            ]
        )
        if float(np.std(drawn)) > 1e-9:
            gain = float(np.clip(np.std(real) / np.std(drawn), 1.0, MAX_GAIN))
            centre = float(real.mean())
            out[:, column] = centre + gain * (means[:, column] - centre)
    out[:, columns + 2] = np.maximum(out[:, columns + 2], 0.0)
    out[:, columns + 3] = np.clip(out[:, columns + 3], 0.0, 1.0)
    return out

"""A standing body in the LMA + HMM method: whether the neighbours stand, and what follows.

Waves, byes, bows and raised hands are performed in place. :func:`stands` tells them from
walks and runs by the neighbours' carried root speed; for them

- the lowest foot point is pinned without the walks' stance hysteresis (``generate_motion``);
- the carried support is made consistent with the lift it gives the body
  (:func:`landed_support`): a hop's flight frames, averaged by the state means with stance
  ones, must not let a foot that is still on the floor glide;
- a cycling movement (a wave) has its cut-off bounded by the neighbours' cycle rate
  (:func:`cycle_rate`), and a slow, small wave whose positions alone do not cycle is
  recognised as cycling by its velocity (:func:`cycles_by_velocity`);
- the arms' spread is widened towards what the path's states hold (:func:`arm_variance`),
  as far as the hands' jerk stays within the neighbours' (:func:`spread_cap`).

docs/motion.md, "Generation", steps 10 and 11.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from mse.motion.base.bodyparts import body_map, limb_groups
from mse.motion.base.bvh import Motion, Skeleton
from mse.motion.base.contacts import supported_at
from mse.motion.base.cycles import leg_length
from mse.motion.base.kinematics import FloatArray
from mse.motion.lma_hmm.hmm import (
    CYCLIC_FRAMES_PER_STATE,
    CYCLIC_RUNS_PER_STATE,
    Encoding,
    TrainedHmm,
    runs_per_state,
    train_hmm,
)
from mse.motion.lma_hmm.pose import with_velocity

#: neighbours whose root moves less than this many leg lengths per second (median) stand
STANDING_LEG_LENGTHS_PER_S = 0.1
#: ... and their legs barely move when 90 % of the legs' rotation channels stay within this
#: range (radians): generated bows of dataset 1 move them 0.20-0.45 (the legs keep upright
#: while the hips fold), waves and byes 0.02-0.12


def cycle_rate(labels: Sequence[npt.NDArray[np.int_]], frame_time: float) -> float:
    """Cycles per second of the neighbours' state sequences (median): the runs of each
    sequence's most often re-entered state per second."""
    rates = []
    for sequence in labels:
        if len(sequence) < 2:
            continue
        starts = sequence[np.r_[True, sequence[1:] != sequence[:-1]]]
        rates.append(float(np.bincount(starts).max()) / (len(sequence) * frame_time))
    return float(np.median(rates)) if rates else 0.0


#: the velocity's weight when a standing body's neighbours are judged again for cycling
#: (:func:`cycles_by_velocity`): dataset 2's feminine waves, Samadani fold 0, runs per state
#: 1.2-2.6 by positions alone, 1.1-2.9 with the velocity at 0.3, 4.1-5.8 at 1
CYCLE_VELOCITY_WEIGHT = 1.0


def cycles_by_velocity(
    phases: Sequence[FloatArray], desired: FloatArray, copies: int, states: int, n_iter: int, weight: float
) -> tuple[TrainedHmm, list[FloatArray], FloatArray] | None:
    """A fully connected HMM of two or more neighbours' ``phases`` with their velocity at
    ``weight`` (and the ``copies`` of the desired path's), with the phases it was fitted on,
    when each neighbour's own path cycles under it (at least ``CYCLIC_RUNS_PER_STATE`` runs per state,
    as ``hmm.train_hmm`` judges positions, on average); else None.

    Feminine waves swing 7 cm at 0.35-0.7 Hz between a slow raising and lowering of the
    arms: positions alone make the states slices of that raising (not cycling), the
    left-to-right chain then averages the neighbours' cycles, which never line up (3 to 5.5
    per clip), and the wave left in the means swung at 0.25 Hz (Samadani fold 0, normal ->
    feminine; floor 0.27). With the velocity the states tell the swing's phases apart and
    the wave keeps the neighbours' tempo (0.70 Hz)."""
    moving = [with_velocity(p, weight) for p in phases]
    typical = float(np.median([len(p) for p in moving])) if moving else 0.0
    # one neighbour: its chain follows its own cycles, there is nothing to average away (the
    # bye of dataset 1, whose tired neighbour cycles by its velocity, went from 19.5 to 15.6
    # cm of hand range with this model, the real clip's 20.2)
    if weight <= 0 or len(moving) < 2 or typical < CYCLIC_FRAMES_PER_STATE * states:
        return None
    own = with_velocity(desired, weight)
    trained = train_hmm(moving + [own] * copies, states, topology="full", n_iter=n_iter, decide_on=len(moving))
    if not trained.cyclic:
        return None
    # every neighbour, not their mean: under a velocity model of dataset 2's feminine waves
    # (the whole library's, from a normal wave) five of eight neighbours sat 100-157 frames in
    # one broad state, their waves swallowed, and the generated wave swung at 0.13 Hz
    if min(runs_per_state(trained.viterbi(p)) for p in moving) < CYCLIC_RUNS_PER_STATE:
        return None
    return trained, moving, own


def stands(carried: Sequence[FloatArray], skeleton: Skeleton) -> bool:
    """Whether the neighbours stand: their root moves (median over their frames) under
    :data:`STANDING_LEG_LENGTHS_PER_S` leg lengths per second."""
    legs = leg_length(skeleton)
    if legs <= 0 or not carried:
        return False
    speed = float(np.median(np.concatenate([np.linalg.norm(c[:, :2], axis=1) for c in carried])))
    return speed < STANDING_LEG_LENGTHS_PER_S * legs


def landed_support(carried: FloatArray) -> FloatArray:
    """``carried`` (frames, 4: root velocity X and Z, lift, support; as
    :func:`~mse.motion.base.contacts.support` gives it) of a standing body, with each frame's
    support raised to what the rise it gives the body says: the root rises by
    ``(1 - support) x lift`` (:func:`~mse.motion.base.contacts.root_track`), and a body
    whose lowest point is within :data:`~mse.motion.base.contacts.FLOOR_BAND` of the floor
    is supported (the rule by which real clips are measured), from twice that not at all.

    The state means average a hop's flight frames with stance ones: dataset 1's active
    byebye hops (13 % of its frames off the floor, up to 17 cm) and its generated support
    never fell below 0.64, so every frame was partly "in flight", rose by under 2 cm and
    moved partly with the carried velocity instead of the pinned foot: the foot on the
    floor slid at 1.20 cm/s (real 0.58, limit 1.2)."""
    out = carried.copy()
    if len(out) == 0:
        return out
    support, lift = out[:, 3], np.maximum(out[:, 2], 0.0)
    rise = (1.0 - support) * lift
    out[:, 3] = np.maximum(support, supported_at(rise))
    return out


#: the arms' rotations of a standing body are widened by at least up to this factor (per
#: channel, standard deviation over time) towards what its states hold (:func:`arm_variance`),
#: and further only as far as the hands' jerk stays within the neighbours' (:func:`spread_cap`):
#: the hands' jerk grows with it (Samadani waves: at 1.5 two conversions went over 2x real,
#: 1.34x and 1.08x the limit; at 1.1 both pass)
ARM_SPREAD_CAP = 1.1


def hand_jerk(motion: Motion) -> float:
    """RMS jerk of the hands about the torso (file units per s^3; third differences of
    positions, as the fidelity bench measures jerk, without the body's own sway)."""
    if motion.frame_count < 4:
        return 0.0
    body = body_map(motion.skeleton)
    positions = motion.positions()
    hands = positions[:, [body.left_hand, body.right_hand]] - positions[:, [body.torso]]
    jerk = np.diff(hands, n=3, axis=0) / motion.frame_time**3
    return float(np.sqrt(np.mean(np.sum(jerk**2, axis=-1))))


def spread_cap(path_jerk: float, neighbours_jerk: Sequence[float], floor: float = ARM_SPREAD_CAP) -> float:
    """How far :func:`arm_variance` may widen the arms: at least ``floor``, and up to the factor
    that brings the path's hand jerk (``path_jerk``, :func:`hand_jerk`) to the neighbours'
    median. Widening the arms' rotations by a factor multiplies the hands' jerk by about as
    much, so a slow movement keeps the room it has and a fast wave stays at ``floor``.

    Dataset 1's not-confident byebye (one neighbour): its hands drift 4.8 cm over 4.7 s, each
    of the 12 states holds a slice of the drift and its mean lies inside it; the states'
    spread is 1.3-3.3x the path's per arm channel, and at 1.1 the hands reached 3.6 cm (the
    spread's low end 4.1) with a jerk of 1,200 against the neighbour's 9,800."""
    if path_jerk <= 0.0 or not neighbours_jerk:
        return floor
    return max(floor, float(np.median(neighbours_jerk)) / path_jerk)


def expected_variance(
    trained: TrainedHmm,
    phases: Sequence[FloatArray],
    values: Sequence[FloatArray],
    states: npt.NDArray[np.int_],
) -> FloatArray:
    """(dims,) the variance over time of a path that draws, for each frame of ``states``,
    the neighbours' own frames of that state (``values`` weighted by the state posteriors of
    the matching ``phases``, as the state means are): the spread the state sequence would
    have if each state kept its frames' spread instead of their mean."""
    weights = np.vstack([trained.posteriors(p) for p in phases])
    stacked = np.vstack(values)
    mass = np.maximum(weights.sum(axis=0), 1e-12)[:, None]
    first = (weights.T @ stacked) / mass
    second = (weights.T @ stacked**2) / mass
    share = np.bincount(states, minlength=weights.shape[1])[: weights.shape[1]] / max(len(states), 1)
    mean = share @ first
    result: FloatArray = np.maximum(share @ second - mean**2, 0.0)
    return result


def arm_variance(
    path: FloatArray,
    means: FloatArray,
    encoding: Encoding,
    target: FloatArray,
    cap: float = ARM_SPREAD_CAP,
) -> tuple[FloatArray, FloatArray]:
    """``path`` and the state ``means`` with each arm rotation channel's spread over time
    widened to ``target`` (per channel: :func:`expected_variance`, what the path's states
    hold), by at most ``cap`` (:func:`spread_cap`), never narrowed: the *global variance* remedy of HMM synthesis
    (Toda and Tokuda 2007, as a variance-scaling post-filter; the HSMM method uses the full
    form), with the variance the states visited give rather than the neighbours' whole
    clips (whose raising and lowering of the arms made a masculine wave drawn from a normal
    one swing 49 cm, over the real masculine waves' 42).

    Every state mean averages the frames the state holds and the low-pass smooths the joins,
    so the hands swing less far than the neighbours': dataset 1's chimpira bye, one
    neighbour, 32 left-to-right states over its 130 frames, hand range 14.2 -> 12.0 cm
    (the spread starts at 12.1). Only the arms: the legs carry the body (the foot pin), the
    trunk's posture is the style's. The means are scaled with the path so that a cycle
    continued by its states (:func:`~mse.motion.lma_hmm.modulated.path_for`) keeps it."""
    groups = limb_groups(encoding.skeleton)
    arms = set(groups["left_arm"]) | set(groups["right_arm"])
    columns = [3 * i + k for i, joint in enumerate(encoding.rotated) if joint in arms for k in range(3)]
    if not columns or len(path) < 2:
        return path, means
    centre = path[:, columns].mean(axis=0)
    own = np.var(path[:, columns], axis=0)
    ratio = np.clip(np.sqrt(target[columns] / np.maximum(own, 1e-12)), 1.0, cap)
    widened, scaled = path.copy(), means.copy()
    widened[:, columns] = centre + ratio * (path[:, columns] - centre)
    scaled[:, columns] = centre + ratio * (means[:, columns] - centre)
    return widened, scaled


def shared_stance(rotations: Sequence[FloatArray], encoding: Encoding) -> list[FloatArray]:
    """The neighbours' rotations with each clip's legs moved to one stance: every clip's leg
    rotation channels keep their movement about the clip's own mean and take the mean of
    all the clips' means as their posture.

    Performers stand with their feet at different widths and angles. A state's mean weighs
    the neighbours that occupy it, so when the state changes the mean stance changes, and
    with one foot pinned the other slides: the feminine waves of dataset 2 generated from
    active ones (Samadani folds 0 and 3), free foot at 1.7 cm/s (real feminine 0.4), which
    the style recognizer took for a youthful wave (real youthful feet: 1.0 cm/s)."""
    legs = set(limb_groups(encoding.skeleton)["legs"])
    columns = [3 * i + k for i, joint in enumerate(encoding.rotated) if joint in legs for k in range(3)]
    if not columns or not rotations:
        return list(rotations)
    means = [r[:, columns].mean(axis=0) for r in rotations]
    posture = np.mean(means, axis=0)
    out = []
    for r, own in zip(rotations, means, strict=True):
        moved = r.copy()
        moved[:, columns] += posture - own
        out.append(moved)
    return out

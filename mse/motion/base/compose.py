"""One body from overlapping motion tracks (the whole-timeline BVH).

Each track is a clip placed at a start time. Per joint, a track contributes its rotation
*relative to the rest pose* (a rotation vector, ``log(R_rest^T R_clip)``). Overlapping
tracks are composed **by body part** (:func:`mse.motion.base.bodyparts.limb_groups`: trunk
and head, left arm, right arm, legs): each track's *activity* on a part is how much it moves
that part (:func:`activity`: the spread of the part's end joints against its root, relative
to the part it moves most),
and where several tracks overlap, each part follows the tracks in proportion to their
activity on it (raised to :data:`DOMINANCE`) — a bow keeps the trunk while a hand-on-mouth
holds the right arm, instead of the two adding up or one hiding the other. Every track fades in and out over
:data:`FADE_SECONDS` (raised cosine), so the weights, and the body, change smoothly at the
edges; a part that no track covers rests.

The root is then placed by the feet (:func:`mse.motion.base.contacts.ground`): the lowest foot
on the floor and pinned, so composed walks travel without sliding. Tracks are resampled to
the composition's frame rate by linear interpolation of the rotation vectors.
"""

from __future__ import annotations

import contextlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from mse.diagnostics import MseError
from mse.motion.base.bodyparts import body_map, limb_groups
from mse.motion.base.bvh import Motion, Skeleton
from mse.motion.base.contacts import contact_height, find_root_joint, ground, runs, support
from mse.motion.base.kinematics import FloatArray, forward_kinematics, matrix_to_euler, rotation_exp, rotation_log

FADE_SECONDS = 0.3
#: weights are the activities to this power: a part's main mover dominates it (a bow's arms
#: hang with 0.3 of the trunk's movement; weighted linearly they held a hand-on-mouth 41 cm
#: from the face, cubed 13 cm as alone), movers of equal activity share it
DOMINANCE = 3.0
#: a track whose activity on a part is below this share of its most active part leaves the
#: part to the other tracks when it overlaps them (it still moves it when alone)
_ACTIVITY_FLOOR = 0.02


@dataclass(frozen=True, eq=False)
class Track:
    start: float
    motion: Motion


def _resample(values: FloatArray, count: int) -> FloatArray:
    if len(values) == count:
        return values
    source = np.linspace(0.0, 1.0, len(values))
    target = np.linspace(0.0, 1.0, count)
    flat = values.reshape(len(values), -1)
    out = np.empty((count, flat.shape[1]))
    for column in range(flat.shape[1]):
        out[:, column] = np.interp(target, source, flat[:, column])
    return out.reshape((count, *values.shape[1:]))


def resample_motion(motion: Motion, duration: float) -> Motion:
    """``motion`` played in exactly ``duration`` seconds at about its frame rate: rotation
    channels unwrapped (no jump from 179 to -179 degrees is interpolated through zero), then
    every channel resampled linearly."""
    frames = max(2, round(duration / motion.frame_time))
    values = motion.values.copy()
    skeleton = motion.skeleton
    columns = [c for j in range(skeleton.joint_count) for c in skeleton.rotation_columns(j)]
    values[:, columns] = np.unwrap(values[:, columns], period=360.0, axis=0)
    return Motion(skeleton, duration / frames, _resample(values, frames))


def fade(count: int, frame_time: float) -> FloatArray:
    """Raised-cosine weights rising over :data:`FADE_SECONDS` and falling at the end."""
    ramp = max(1, min(count // 2, round(FADE_SECONDS / frame_time)))
    weights = np.ones(count)
    rise = 0.5 - 0.5 * np.cos(np.pi * (np.arange(ramp) + 0.5) / ramp)
    weights[:ramp] = rise
    weights[count - ramp :] = np.minimum(weights[count - ramp :], rise[::-1])
    return weights


def _chains(skeleton: Skeleton, groups: Mapping[str, Sequence[int]]) -> list[tuple[int, list[int]]]:
    """Per part: its root joint (for the trunk, the hips) and its end joints (leaves)."""
    hips = -1
    with contextlib.suppress(MseError):
        hips = skeleton.parents[body_map(skeleton).left_hip]
    chains: list[tuple[int, list[int]]] = []
    for joints in groups.values():
        members = set(joints)
        if not members:
            chains.append((-1, []))
            continue
        root = hips if hips in members else next(j for j in joints if skeleton.parents[j] not in members)
        ends = [j for j in joints if not any(c in members for c in skeleton.children(j))]
        chains.append((root, ends))
    return chains


def activity(motion: Motion, chains: Sequence[tuple[int, Sequence[int]]]) -> FloatArray:
    """(parts,) how much a track moves each part: the spread over time of the part's end
    joints (hand, head, feet) relative to its root joint, in the frame of the root's
    parent, divided by the largest part's. A bow's hanging arms barely move against the
    chest (while their joints turn a little); a hand-on-mouth's wrist travels half a metre."""
    positions, world = forward_kinematics(motion.skeleton.parents, motion.translations(), motion.local_rotations())
    values = []
    for root, ends in chains:
        if root < 0 or not ends:
            values.append(0.0)
            continue
        parent = motion.skeleton.parents[root]
        frame = world[:, parent] if parent >= 0 else np.broadcast_to(np.eye(3), (motion.frame_count, 3, 3))
        offsets = np.einsum("fba,fkb->fka", frame, positions[:, ends] - positions[:, root : root + 1])
        values.append(float(np.linalg.norm(offsets - offsets.mean(axis=0), axis=-1).mean()))
    result = np.array(values)
    top = float(result.max()) if len(result) else 0.0
    share: FloatArray = result / top if top > 1e-9 else np.ones(len(result))
    return share


def compose(rest: Motion, tracks: Sequence[Track], duration: float, frame_time: float = 1.0 / 30.0) -> Motion:
    """A clip of ``duration`` seconds: ``rest``'s first frame, with the tracks composed on it.

    Tracks must share ``rest``'s skeleton layout (callers filter the others out)."""
    skeleton = rest.skeleton
    frames = max(1, round(duration / frame_time))
    frame_time = duration / frames
    rest_values = rest.values[0]
    rest_rotations = rest.slice(0, 1).local_rotations()[0]  # (J, 3, 3)
    rotated = [j for j in range(skeleton.joint_count) if len(skeleton.rotation_order(j)) == 3]
    parts = limb_groups(skeleton)
    names = list(parts)
    chains = _chains(skeleton, parts)
    # the parts as indices into ``rotated``
    groups = [[rotated.index(j) for j in parts[name] if j in rotated] for name in names]
    part_of = np.zeros(len(rotated), dtype=int)
    for index, group in enumerate(groups):
        part_of[group] = index
    inverse_rest = np.swapaxes(rest_rotations[rotated], -1, -2)
    weighted = np.zeros((frames, len(rotated), 3))
    total = np.zeros((frames, len(names)))
    presence = np.zeros((frames, len(names)))
    # runs' flight phases, carried into the grounding (see _carried)
    legs = names.index("legs") if "legs" in names else None
    carried_sum = np.zeros((frames, 4))
    carried_weight = np.zeros(frames)
    for track in tracks:
        motion = track.motion
        first = round(track.start / frame_time)
        count = max(1, round(motion.duration / frame_time))
        lo, hi = max(0, first), min(frames, first + count)
        if hi <= lo:
            continue
        relative = rotation_log(inverse_rest[None] @ motion.local_rotations()[:, rotated])
        relative = _resample(relative, count)[lo - first : hi - first]
        edges = fade(count, frame_time)[lo - first : hi - first]
        share = np.maximum(activity(motion, chains), _ACTIVITY_FLOOR) ** DOMINANCE  # (parts,)
        weights = edges[:, None] * share[None, :]  # (frames, parts)
        weighted[lo:hi] += relative * weights[:, part_of][:, :, None]
        total[lo:hi] += weights
        presence[lo:hi] = np.maximum(presence[lo:hi], edges[:, None])
        if legs is not None:
            own = support(motion)
            if runs(own[:, 3]):
                own[:, :2] = _root_velocity(motion)
                carried_sum[lo:hi] += _resample(own, count)[lo - first : hi - first] * weights[:, legs, None]
                carried_weight[lo:hi] += weights[:, legs]
    # each part: the activity-weighted mean of the tracks on it, faded by the strongest edge
    mixed = weighted / np.maximum(total[:, part_of], 1e-12)[:, :, None] * presence[:, part_of][:, :, None]
    values = np.tile(rest_values, (frames, 1))
    matrices = rest_rotations[rotated][None] @ rotation_exp(mixed)
    for k, joint in enumerate(rotated):
        columns = list(skeleton.rotation_columns(joint))
        values[:, columns] = matrix_to_euler(matrices[:, k], skeleton.rotation_order(joint))
    composed = Motion(skeleton, frame_time, values)
    return ground(composed, contact_height([rest]), carried=_carried(carried_sum, carried_weight, total, legs))


def _carried(
    carried_sum: FloatArray, carried_weight: FloatArray, total: FloatArray, legs: int | None
) -> FloatArray | None:
    """How running tracks carry the root (as :func:`mse.motion.base.contacts.support`'s
    columns), or None when no track runs: where running tracks hold the legs, the root
    moves with their own root (each track's generator grounded it through its flight
    phases), in proportion to their share of the legs; elsewhere the feet place it.

    Re-grounded from the feet alone, a composed run lost its flight and its stance foot slid
    (dataset 1, LMA + HMM, one track: the musical run 243 → 167 cm/s, foot slip 13 → 124
    cm/s; the normal dash 415 → 155, slip 70)."""
    if legs is None or not np.any(carried_weight > 0):
        return None
    share = np.clip(carried_weight / np.maximum(total[:, legs], 1e-12), 0.0, 1.0)
    carried = carried_sum / np.maximum(carried_weight, 1e-12)[:, None]
    carried[:, 3] = 1.0 - share
    return carried


def _root_velocity(motion: Motion) -> FloatArray:
    """(T, 2) the root's horizontal velocity as the steps :func:`contacts.root_track` adds up
    (frame ``t`` minus frame ``t - 1``; central differences let the stance foot slide)."""
    root = motion.positions()[:, find_root_joint(motion)][:, [0, 2]]
    steps = np.vstack([np.zeros((1, 2)), np.diff(root, axis=0)])
    velocity: FloatArray = steps / motion.frame_time
    return velocity

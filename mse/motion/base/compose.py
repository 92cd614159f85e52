"""One body from overlapping motion tracks (the whole-timeline BVH).

Each track is a clip placed at a start time. Per joint, a track contributes its rotation
*relative to the rest pose* (a rotation vector, ``log(R_rest^T R_clip)``). Overlapping
tracks are composed **by body part** (:func:`mse.motion.base.bodyparts.limb_groups`: trunk
and head, left arm, right arm, legs): each track's *activity* on a part is how much it moves
that part (the spread over time of its rotations there, relative to the part it moves most),
and where several tracks overlap, each part follows the tracks in proportion to their
activity on it — a bow keeps the trunk while a hand-on-mouth holds the right arm, instead of
the two adding up or one hiding the other. Every track fades in and out over
:data:`FADE_SECONDS` (raised cosine), so the weights, and the body, change smoothly at the
edges; a part that no track covers rests.

The root is then placed by the feet (:func:`mse.motion.base.contacts.ground`): the lowest foot
on the floor and pinned, so composed walks travel without sliding. Tracks are resampled to
the composition's frame rate by linear interpolation of the rotation vectors.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mse.motion.base.bodyparts import limb_groups
from mse.motion.base.bvh import Motion
from mse.motion.base.contacts import contact_height, ground
from mse.motion.base.kinematics import FloatArray, matrix_to_euler, rotation_exp, rotation_log

FADE_SECONDS = 0.3
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


def fade(count: int, frame_time: float) -> FloatArray:
    """Raised-cosine weights rising over :data:`FADE_SECONDS` and falling at the end."""
    ramp = max(1, min(count // 2, round(FADE_SECONDS / frame_time)))
    weights = np.ones(count)
    rise = 0.5 - 0.5 * np.cos(np.pi * (np.arange(ramp) + 0.5) / ramp)
    weights[:ramp] = rise
    weights[count - ramp :] = np.minimum(weights[count - ramp :], rise[::-1])
    return weights


def activity(relative: FloatArray, groups: Sequence[Sequence[int]]) -> FloatArray:
    """(parts,) how much a track moves each part: the mean over the part's joints of the
    spread over time of the rotation vectors, divided by the largest part's."""
    spread = np.linalg.norm(relative - relative.mean(axis=0), axis=-1).mean(axis=0)  # (joints,)
    values = np.array([float(spread[list(g)].mean()) if len(g) else 0.0 for g in groups])
    top = float(values.max()) if len(values) else 0.0
    return values / top if top > 1e-9 else np.ones(len(groups))


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
    # the parts as indices into ``rotated``
    groups = [[rotated.index(j) for j in parts[name] if j in rotated] for name in names]
    part_of = np.zeros(len(rotated), dtype=int)
    for index, group in enumerate(groups):
        part_of[group] = index
    inverse_rest = np.swapaxes(rest_rotations[rotated], -1, -2)
    weighted = np.zeros((frames, len(rotated), 3))
    total = np.zeros((frames, len(names)))
    presence = np.zeros((frames, len(names)))
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
        share = np.maximum(activity(relative, groups), _ACTIVITY_FLOOR)  # (parts,)
        weights = edges[:, None] * share[None, :]  # (frames, parts)
        weighted[lo:hi] += relative * weights[:, part_of][:, :, None]
        total[lo:hi] += weights
        presence[lo:hi] = np.maximum(presence[lo:hi], edges[:, None])
    # each part: the activity-weighted mean of the tracks on it, faded by the strongest edge
    mixed = weighted / np.maximum(total[:, part_of], 1e-12)[:, :, None] * presence[:, part_of][:, :, None]
    values = np.tile(rest_values, (frames, 1))
    matrices = rest_rotations[rotated][None] @ rotation_exp(mixed)
    for k, joint in enumerate(rotated):
        columns = list(skeleton.rotation_columns(joint))
        values[:, columns] = matrix_to_euler(matrices[:, k], skeleton.rotation_order(joint))
    composed = Motion(skeleton, frame_time, values)
    return ground(composed, contact_height([rest]))

"""Composing motion tracks into one clip over a rest pose (the whole-timeline BVH).

Each track is a clip placed at a start time. Per joint, a track contributes its rotation
*relative to the rest pose* (a rotation vector, ``log(R_rest^T R_clip)``) and, for position
channels, its displacement from the rest values; overlapping tracks add up. Every track fades
in and out over :data:`FADE_SECONDS` (raised cosine) so that a clip that does not end at rest
does not pop. Tracks are resampled to the composition's frame rate by linear interpolation of
those relative quantities.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mse.motion.base.bvh import Motion
from mse.motion.base.kinematics import FloatArray, matrix_to_euler, rotation_exp, rotation_log

FADE_SECONDS = 0.2


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


def _fade(count: int, frame_time: float) -> FloatArray:
    ramp = max(1, min(count // 2, round(FADE_SECONDS / frame_time)))
    weights = np.ones(count)
    rise = 0.5 - 0.5 * np.cos(np.pi * (np.arange(ramp) + 0.5) / ramp)
    weights[:ramp] = rise
    weights[count - ramp :] = np.minimum(weights[count - ramp :], rise[::-1])
    return weights


def compose(rest: Motion, tracks: Sequence[Track], duration: float, frame_time: float = 1.0 / 30.0) -> Motion:
    """A clip of ``duration`` seconds: ``rest``'s first frame, plus every track's motion.

    Tracks must share ``rest``'s skeleton layout (callers filter the others out)."""
    skeleton = rest.skeleton
    frames = max(1, round(duration / frame_time))
    frame_time = duration / frames
    rest_values = rest.values[0]
    rest_rotations = rest.slice(0, 1).local_rotations()[0]  # (J, 3, 3)
    rotated = [j for j in range(skeleton.joint_count) if len(skeleton.rotation_order(j)) == 3]
    position_columns = [c for j in range(skeleton.joint_count) for c in skeleton.position_columns(j)]
    rotation_sum = np.zeros((frames, len(rotated), 3))
    position_sum = np.zeros((frames, len(position_columns)))
    inverse_rest = np.swapaxes(rest_rotations[rotated], -1, -2)
    for track in tracks:
        motion = track.motion
        first = round(track.start / frame_time)
        count = max(1, round(motion.duration / frame_time))
        lo, hi = max(0, first), min(frames, first + count)
        if hi <= lo:
            continue
        relative = rotation_log(inverse_rest[None] @ motion.local_rotations()[:, rotated])
        shift = motion.values[:, position_columns] - rest_values[position_columns]
        weights = _fade(count, frame_time)[lo - first : hi - first, None]
        rotation_sum[lo:hi] += _resample(relative, count)[lo - first : hi - first] * weights[:, :, None]
        position_sum[lo:hi] += _resample(shift, count)[lo - first : hi - first] * weights
    values = np.tile(rest_values, (frames, 1))
    matrices = rest_rotations[rotated][None] @ rotation_exp(rotation_sum)
    for k, joint in enumerate(rotated):
        columns = list(skeleton.rotation_columns(joint))
        values[:, columns] = matrix_to_euler(matrices[:, k], skeleton.rotation_order(joint))
    values[:, position_columns] += position_sum
    return Motion(skeleton, frame_time, values)

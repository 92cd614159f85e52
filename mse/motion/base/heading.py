"""Which way a clip faces, and turning it about the vertical axis.

Performers face different ways in the room (Bandai's takes of a style do not share a
heading), so rotations of the root joint mix the body's own motion with the room direction.
Averaging them over clips (the LMA + HMM state means) or comparing them needs the clips
turned to one heading first: :func:`heading` is the mean facing direction (forward = the
hips' left-right axis x up, averaged over the clip as a unit vector), :func:`turned` rotates a
clip about the vertical through the world origin (root rotation and root position).
"""

from __future__ import annotations

import numpy as np

from mse.motion.base.bodyparts import body_map
from mse.motion.base.bvh import Motion
from mse.motion.base.contacts import find_root_joint
from mse.motion.base.kinematics import FloatArray, forward_kinematics, matrix_to_euler


def heading(motion: Motion) -> float:
    """Mean facing direction (radians about +Y, 0 = facing +Z, positive towards +X)."""
    body = body_map(motion.skeleton)
    positions = motion.positions()
    lateral = positions[:, body.left_hip] - positions[:, body.right_hip]
    yaw = np.arctan2(-lateral[:, 2], lateral[:, 0])  # forward = lateral x up, Y up
    return float(np.arctan2(np.mean(np.sin(yaw)), np.mean(np.cos(yaw))))


def _yaw(angle: float) -> FloatArray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def turned(motion: Motion, angle: float) -> Motion:
    """``motion`` turned by ``angle`` radians about the vertical through the origin."""
    if abs(angle) < 1e-12 or motion.frame_count == 0:
        return motion
    skeleton = motion.skeleton
    root = find_root_joint(motion)
    order = skeleton.rotation_order(root)
    parent = skeleton.parents[root]
    turn = _yaw(angle)
    _, world = forward_kinematics(skeleton.parents, motion.translations()[:1], motion.local_rotations()[:1])
    # the root's parent (Bandai's joint_Root) is static: turn in its frame
    frame = world[0, parent] if parent >= 0 else np.eye(3)
    local_turn = frame.T @ turn @ frame
    values = motion.values.copy()
    if len(order) == 3:
        rotations = local_turn[None] @ motion.local_rotations()[:, root]
        values[:, list(skeleton.rotation_columns(root))] = matrix_to_euler(rotations, order)
    columns = list(skeleton.position_columns(root))
    if columns:
        values[:, columns] = values[:, columns] @ local_turn.T
    return motion.with_values(values)


# --- the path's heading along a clip: turning locomotion -----------------------------------
#
# A turning walk's heading changes as it goes: measures taken in one frame for the whole clip
# (the first frame's forward axis, a straight line from start to end, the main axis of the
# feet's separation) bend with the path. :func:`heading_track` is the heading the path follows,
# frame by frame (the hips' facing with the pelvis' sway averaged out over
# :data:`HEADING_SMOOTH_S`), :func:`in_heading_frame` expresses horizontal vectors in it, and
# :func:`turn_rate` is how fast it turns. Bandai's straight locomotion (dataset 1 walks of
# every direction, runs, dashes; dataset 2 walks) turns 0-28 deg over a clip, at most
# 5.7 deg/s; a turning walk's clip turns 97-99 deg.

#: the pelvis swings the hips' facing by a few degrees at every step: averaged over this long
#: (s, about one cycle of two steps) the facing follows the path
HEADING_SMOOTH_S = 1.0
#: locomotion turns when its clips' median turn rate is at least this many degrees per second
#: (see above: straight Bandai locomotion at most 5.7, a turning walk about 20)
TURN_DEG_PER_S = 10.0


def facing_yaws(positions: FloatArray, left: int, right: int) -> FloatArray:
    """(T,) facing direction per frame (radians about +Y, 0 = +Z, positive towards +X; forward
    = the ``left`` - ``right`` joint vector x up), unwrapped along time."""
    lateral = positions[:, left] - positions[:, right]
    result: FloatArray = np.unwrap(np.arctan2(-lateral[:, 2], lateral[:, 0]))
    return result


def smoothed_yaws(yaws: FloatArray, frame_time: float, smooth_s: float = HEADING_SMOOTH_S) -> FloatArray:
    """Unwrapped ``yaws`` (T,) averaged over ``smooth_s``; near the ends the average is
    extended along the clip's own turn (a mirrored pad), so a steady turn is not flattened."""
    yaws = np.asarray(yaws, dtype=np.float64)
    window = max(1, round(smooth_s / frame_time)) | 1
    if window < 3 or yaws.size < 3:
        return yaws.copy()
    half = min(window // 2, yaws.size - 1)
    padded = np.pad(yaws, (half, half), mode="reflect", reflect_type="odd")
    kernel = np.ones(2 * half + 1) / (2 * half + 1)
    result: FloatArray = np.convolve(padded, kernel, mode="valid")
    return result


def heading_track(motion: Motion, positions: FloatArray | None = None) -> FloatArray:
    """(T,) the heading of the path per frame (:func:`smoothed_yaws` of the hips' facing)."""
    body = body_map(motion.skeleton)
    world = motion.positions() if positions is None else positions
    return smoothed_yaws(facing_yaws(world, body.left_hip, body.right_hip), motion.frame_time)


def in_heading_frame(vectors: FloatArray, yaws: FloatArray) -> FloatArray:
    """Horizontal vectors (T, 2) as (x, z) in each frame's heading frame (the heading along +Z)."""
    c, s = np.cos(yaws), np.sin(yaws)
    x, z = vectors[:, 0], vectors[:, 1]
    result: FloatArray = np.stack([c * x - s * z, s * x + c * z], axis=1)
    return result


def turn_rate(motion: Motion, positions: FloatArray | None = None) -> float:
    """Radians per second the clip's facing turns (the sign of :func:`heading`: from +Z
    towards +X): the least-squares slope of the hips' unwrapped facing over time (the
    pelvis' sway averages out)."""
    if motion.frame_count < 3:
        return 0.0
    body = body_map(motion.skeleton)
    world = motion.positions() if positions is None else positions
    yaws = facing_yaws(world, body.left_hip, body.right_hip)
    times = np.arange(yaws.size) * motion.frame_time
    return float(np.polyfit(times, yaws, 1)[0])


def turning_rate(motions: list[Motion]) -> float:
    """The clips' median :func:`turn_rate` (rad/s) when its magnitude is at least
    :data:`TURN_DEG_PER_S`, else 0 (the action goes straight)."""
    if not motions:
        return 0.0
    rate = float(np.median([turn_rate(m) for m in motions]))
    return rate if abs(np.degrees(rate)) >= TURN_DEG_PER_S else 0.0


def _yaws(angles: FloatArray) -> FloatArray:
    """(T, 3, 3) rotations about +Y by ``angles`` (the convention of :func:`_yaw`)."""
    c, s = np.cos(angles), np.sin(angles)
    out = np.zeros((angles.size, 3, 3))
    out[:, 0, 0], out[:, 0, 2], out[:, 1, 1], out[:, 2, 0], out[:, 2, 2] = c, s, 1.0, -s, c
    return out


def turned_along(motion: Motion, angles: FloatArray) -> Motion:
    """``motion`` with frame t turned by ``angles[t]`` radians about the vertical: the root's
    rotation, and each horizontal step of its position by the turn of the frame it ends in
    (a path that bends as the angle changes; the first frame stays where it is)."""
    angles = np.asarray(angles, dtype=np.float64)
    if motion.frame_count == 0 or not np.any(angles):
        return motion
    skeleton = motion.skeleton
    root = find_root_joint(motion)
    parent = skeleton.parents[root]
    _, world = forward_kinematics(skeleton.parents, motion.translations()[:1], motion.local_rotations()[:1])
    # the root's parent (Bandai's joint_Root) is static: turn in its frame
    frame = world[0, parent] if parent >= 0 else np.eye(3)
    local_turns = frame.T[None] @ _yaws(angles) @ frame[None]
    values = motion.values.copy()
    order = skeleton.rotation_order(root)
    if len(order) == 3:
        rotations = local_turns @ motion.local_rotations()[:, root]
        values[:, list(skeleton.rotation_columns(root))] = matrix_to_euler(rotations, order)
    columns = list(skeleton.position_columns(root))
    if columns:
        local = values[:, columns]
        steps = np.diff(local, axis=0)
        turned_steps = np.einsum("fij,fj->fi", local_turns[1:], steps)
        values[:, columns] = np.vstack([local[:1], local[:1] + np.cumsum(turned_steps, axis=0)])
    return motion.with_values(values)


def straightened(motion: Motion) -> Motion:
    """``motion`` turned back frame by frame by its path's heading (:func:`heading_track`):
    a turning walk becomes a straight walk facing +Z, its steps unchanged (the pelvis' sway
    about the path stays)."""
    return turned_along(motion, -heading_track(motion))

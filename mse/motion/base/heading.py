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

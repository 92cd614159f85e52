"""Play a clip on another skeleton whose joints have the same names (retargeting).

The starter library uses Bandai's joint names, so a starter fallback next to Bandai clips can
join them on one body. Each matched joint keeps its *world* rotation relative to the rest
pose: with ``W`` the world rotations, ``W_target(t) = W_source(t) W_source_rest^T
W_target_rest``, then back to local rotations; joints without a match keep the target's rest
pose relative to their parent. Both rest poses must be the same posture (standing, arms
down: the starter's zero pose and the first frame of a Bandai clip are). The root's position
is left to :func:`mse.motion.base.contacts.ground` by the caller.
"""

from __future__ import annotations

import numpy as np

from mse.motion.base.bvh import Motion
from mse.motion.base.kinematics import forward_kinematics, matrix_to_euler

#: at least this share of the target's rotated joints must have a source joint of that name
MIN_MATCHED = 0.8


def matched_joints(source: Motion, target: Motion) -> dict[int, int] | None:
    """Target joint -> source joint by name, or None when too few match."""
    names = {name: index for index, name in enumerate(source.skeleton.names)}
    skeleton = target.skeleton
    rotated = [j for j in range(skeleton.joint_count) if len(skeleton.rotation_order(j)) == 3]
    pairs = {j: names[skeleton.names[j]] for j in rotated if skeleton.names[j] in names}
    usable = {j: s for j, s in pairs.items() if len(source.skeleton.rotation_order(s)) == 3}
    return usable if rotated and len(usable) >= MIN_MATCHED * len(rotated) else None


def _world(motion: Motion) -> np.ndarray:
    _, world = forward_kinematics(motion.skeleton.parents, motion.translations(), motion.local_rotations())
    return world


def retarget(source: Motion, source_rest: Motion, target_rest: Motion) -> Motion | None:
    """``source`` on ``target_rest``'s skeleton at ``source``'s frame rate (its first frame
    is the target's rest pose), or None when the joint names do not match."""
    pairs = matched_joints(source, target_rest)
    if pairs is None:
        return None
    skeleton = target_rest.skeleton
    frames = source.frame_count
    world_source = _world(source)  # (F, Js, 3, 3)
    rest_source = _world(source_rest.slice(0, 1))[0]
    rest_target_local = target_rest.slice(0, 1).local_rotations()[0]
    rest_target = _world(target_rest.slice(0, 1))[0]
    world = np.empty((frames, skeleton.joint_count, 3, 3))
    local = np.empty_like(world)
    for joint, parent in enumerate(skeleton.parents):
        if joint in pairs:
            s = pairs[joint]
            world[:, joint] = world_source[:, s] @ rest_source[s].T @ rest_target[joint]
        elif parent >= 0:
            world[:, joint] = world[:, parent] @ rest_target_local[joint]
        else:
            world[:, joint] = rest_target[joint]
        local[:, joint] = world[:, joint] if parent < 0 else np.swapaxes(world[:, parent], -1, -2) @ world[:, joint]
    values = np.tile(target_rest.values[0], (frames, 1))
    for joint in range(skeleton.joint_count):
        order = skeleton.rotation_order(joint)
        if len(order) == 3:
            values[:, list(skeleton.rotation_columns(joint))] = matrix_to_euler(local[:, joint], order)
    return Motion(skeleton, source.frame_time, values)

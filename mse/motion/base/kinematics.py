"""Rotations and forward kinematics on numpy arrays (no I/O, no heavy imports).

Conventions (those of BVH):
- Euler angles are in degrees; an order such as ``"ZXY"`` lists the rotation channels as they
  appear in the file, and the local rotation is ``R = Rz @ Rx @ Ry`` (intrinsic, left to right).
- Rotations act on column vectors: a child's world position is
  ``p_parent + R_parent_world @ translation`` and ``R_world = R_parent_world @ R_local``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]

_AXES = {"X": 0, "Y": 1, "Z": 2}


def axis_rotation(axis: str, degrees: FloatArray) -> FloatArray:
    """Rotation matrices (..., 3, 3) about one axis for an array of angles in degrees."""
    radians = np.deg2rad(np.asarray(degrees, dtype=np.float64))
    cos, sin = np.cos(radians), np.sin(radians)
    out = np.zeros((*radians.shape, 3, 3), dtype=np.float64)
    i = _AXES[axis]
    j, k = (i + 1) % 3, (i + 2) % 3
    out[..., i, i] = 1.0
    out[..., j, j] = cos
    out[..., k, k] = cos
    out[..., j, k] = -sin
    out[..., k, j] = sin
    return out


def euler_to_matrix(angles: FloatArray, order: str) -> FloatArray:
    """(..., 3) Euler angles in degrees, in channel ``order``, to (..., 3, 3) matrices."""
    angles = np.asarray(angles, dtype=np.float64)
    result = axis_rotation(order[0], angles[..., 0])
    for position in (1, 2):
        result = result @ axis_rotation(order[position], angles[..., position])
    return result


def matrix_to_euler(matrices: FloatArray, order: str) -> FloatArray:
    """(..., 3, 3) rotation matrices to (..., 3) Euler angles in degrees for ``order``.

    Works for the six Tait-Bryan orders; at gimbal lock the third angle is set to zero.
    """
    m = np.asarray(matrices, dtype=np.float64)
    i, j, k = (_AXES[a] for a in order)
    # sign of the permutation (i, j, k): +1 for cyclic orders XYZ, YZX, ZXY.
    sign = 1.0 if (j - i) % 3 == 1 else -1.0
    middle = np.arcsin(np.clip(sign * m[..., i, k], -1.0, 1.0))
    cos_middle = np.cos(middle)
    regular = np.abs(cos_middle) > 1e-9
    first = np.where(
        regular,
        np.arctan2(-sign * m[..., j, k], m[..., k, k]),
        np.arctan2(sign * m[..., k, j], m[..., j, j]),
    )
    third = np.where(regular, np.arctan2(-sign * m[..., i, j], m[..., i, i]), 0.0)
    angles: FloatArray = np.rad2deg(np.stack([first, middle, third], axis=-1))
    return angles


def forward_kinematics(
    parents: Sequence[int],
    translations: FloatArray,
    local_rotations: FloatArray,
) -> tuple[FloatArray, FloatArray]:
    """World positions (F, J, 3) and world rotations (F, J, 3, 3).

    ``translations`` (F, J, 3) are each joint's offset from its parent (for the root: its
    world position); ``local_rotations`` (F, J, 3, 3); parents must precede children.
    """
    frames, joints = translations.shape[:2]
    positions = np.empty((frames, joints, 3), dtype=np.float64)
    rotations = np.empty((frames, joints, 3, 3), dtype=np.float64)
    for joint, parent in enumerate(parents):
        if parent < 0:
            positions[:, joint] = translations[:, joint]
            rotations[:, joint] = local_rotations[:, joint]
            continue
        parent_rotation = rotations[:, parent]
        positions[:, joint] = positions[:, parent] + np.einsum("fab,fb->fa", parent_rotation, translations[:, joint])
        rotations[:, joint] = parent_rotation @ local_rotations[:, joint]
    return positions, rotations


def rotation_log(matrices: FloatArray) -> FloatArray:
    """(..., 3, 3) rotations to (..., 3) rotation vectors (axis x angle, radians)."""
    m = np.asarray(matrices, dtype=np.float64)
    cos = np.clip((np.trace(m, axis1=-2, axis2=-1) - 1.0) / 2.0, -1.0, 1.0)
    angle = np.arccos(cos)
    skew = np.stack(
        [m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] - m[..., 0, 1]],
        axis=-1,
    )
    sin = np.sin(angle)
    small = sin < 1e-6
    factor = np.where(small, 0.5 + angle**2 / 12.0, angle / (2.0 * np.where(small, 1.0, sin)))
    vectors: FloatArray = skew * factor[..., None]
    near_pi = small & (angle > 1.0)
    if np.any(near_pi):  # angle ~ pi: the axis is the dominant column of (R + I) / 2
        sym = (m[near_pi] + np.eye(3)) / 2.0
        column = np.argmax(np.diagonal(sym, axis1=-2, axis2=-1), axis=-1)
        axes = sym[np.arange(len(sym)), :, column]
        axes /= np.linalg.norm(axes, axis=-1, keepdims=True)
        vectors[near_pi] = axes * angle[near_pi][..., None]
    return vectors


def rotation_exp(vectors: FloatArray) -> FloatArray:
    """(..., 3) rotation vectors (radians) to (..., 3, 3) matrices (Rodrigues)."""
    v = np.asarray(vectors, dtype=np.float64)
    angle = np.linalg.norm(v, axis=-1)
    small = angle < 1e-8
    safe = np.where(small, 1.0, angle)
    a = np.where(small, 1.0 - angle**2 / 6.0, np.sin(safe) / safe)
    b = np.where(small, 0.5 - angle**2 / 24.0, (1.0 - np.cos(safe)) / safe**2)
    skew = np.zeros((*v.shape[:-1], 3, 3), dtype=np.float64)
    skew[..., 0, 1], skew[..., 0, 2] = -v[..., 2], v[..., 1]
    skew[..., 1, 0], skew[..., 1, 2] = v[..., 2], -v[..., 0]
    skew[..., 2, 0], skew[..., 2, 1] = -v[..., 1], v[..., 0]
    out: FloatArray = np.eye(3) + a[..., None, None] * skew + b[..., None, None] * (skew @ skew)
    return out


def mean_rotation(matrices: FloatArray) -> FloatArray:
    """Chordal mean of (N, 3, 3) rotations: the SO(3) projection of their average."""
    u, _, vt = np.linalg.svd(np.mean(matrices, axis=0))
    if np.linalg.det(u @ vt) < 0:
        u[:, -1] = -u[:, -1]
    mean: FloatArray = u @ vt
    return mean

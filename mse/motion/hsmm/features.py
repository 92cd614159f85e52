"""Rotation parameterisation and dynamic features (paper §4 and §5.1.1, eq. 1–4).

Joint rotations are exponential maps ``r = θ u`` (eq. 1).  Each joint's rotation is taken
relative to a per-joint reference rotation (the chordal mean over the training data) so that
the angles stay far from π, where the exponential map is singular and has two branches;
sign-continuous quaternions along time keep a sequence on one branch.

The observation vector is ``o_t = [c_t, Δc_t, Δ²c_t]`` with HTS's windows
``Δc_t = (c_{t+1} - c_{t-1}) / 2`` and ``Δ²c_t = c_{t+1} - 2 c_t + c_{t-1}``.  (The paper's
eq. 3 written as the Δ of the Δ, ``(c_{t+2} - 2 c_t + c_{t-2}) / 4``, links only frames of
the same parity: parameter generation then lets odd and even frames drift apart, and the hands
reversed direction on 95 % of the frames of generated bows against 1 % with [1, -2, 1].)  Frames
outside the sequence repeat the edge frame, and the same clamped windows build the matrix
``W`` of ``O = W C`` (eq. 4) used by parameter generation, so the two always agree.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from mse.motion.base.kinematics import mean_rotation as mean_rotation  # re-exported for the HSMM modules
from mse.motion.base.kinematics import rotation_exp

FloatArray = npt.NDArray[np.float64]

#: Window offsets and coefficients of the static, Δ and Δ² streams (HTS: [-0.5, 0, 0.5] and
#: [1, -2, 1]).
WINDOWS: tuple[tuple[tuple[int, float], ...], ...] = (
    ((0, 1.0),),
    ((-1, -0.5), (1, 0.5)),
    ((-1, 1.0), (0, -2.0), (1, 1.0)),
)
#: Largest |offset| of any window: the half bandwidth of ``W`` is this, of ``WᵀW`` twice it.
WINDOW_REACH = 1


# -- rotations ----------------------------------------------------------------------------
def quaternion_from_matrix(matrices: FloatArray) -> FloatArray:
    """(..., 3, 3) rotation matrices to (..., 4) unit quaternions ``(w, x, y, z)``, w ≥ 0."""
    m = np.asarray(matrices, dtype=np.float64)
    trace = m[..., 0, 0] + m[..., 1, 1] + m[..., 2, 2]
    # 4w², 4x², 4y², 4z² from the diagonal; take the largest for numerical stability.
    squares = np.stack(
        [
            1.0 + trace,
            1.0 + m[..., 0, 0] - m[..., 1, 1] - m[..., 2, 2],
            1.0 - m[..., 0, 0] + m[..., 1, 1] - m[..., 2, 2],
            1.0 - m[..., 0, 0] - m[..., 1, 1] + m[..., 2, 2],
        ],
        axis=-1,
    )
    best = np.argmax(squares, axis=-1)
    quats = np.empty((*m.shape[:-2], 4), dtype=np.float64)
    candidates = [
        np.stack(
            [
                squares[..., 0],
                m[..., 2, 1] - m[..., 1, 2],
                m[..., 0, 2] - m[..., 2, 0],
                m[..., 1, 0] - m[..., 0, 1],
            ],
            axis=-1,
        ),
        np.stack(
            [
                m[..., 2, 1] - m[..., 1, 2],
                squares[..., 1],
                m[..., 0, 1] + m[..., 1, 0],
                m[..., 0, 2] + m[..., 2, 0],
            ],
            axis=-1,
        ),
        np.stack(
            [
                m[..., 0, 2] - m[..., 2, 0],
                m[..., 0, 1] + m[..., 1, 0],
                squares[..., 2],
                m[..., 1, 2] + m[..., 2, 1],
            ],
            axis=-1,
        ),
        np.stack(
            [
                m[..., 1, 0] - m[..., 0, 1],
                m[..., 0, 2] + m[..., 2, 0],
                m[..., 1, 2] + m[..., 2, 1],
                squares[..., 3],
            ],
            axis=-1,
        ),
    ]
    for index, candidate in enumerate(candidates):
        chosen = best == index
        quats[chosen] = candidate[chosen]
    quats /= np.linalg.norm(quats, axis=-1, keepdims=True)
    quats *= np.where(quats[..., :1] < 0.0, -1.0, 1.0)
    return quats


def expmap_from_quaternion(quats: FloatArray) -> FloatArray:
    """(..., 4) quaternions to (..., 3) exponential maps; w < 0 gives angles above π."""
    q = np.asarray(quats, dtype=np.float64)
    vector = q[..., 1:]
    sine = np.linalg.norm(vector, axis=-1)
    angle = 2.0 * np.arctan2(sine, q[..., 0])
    # θ/sin(θ/2) → 2 as θ → 0: use the limit to avoid 0/0.
    scale = np.where(sine > 1e-12, angle / np.maximum(sine, 1e-300), 2.0)
    result: FloatArray = vector * scale[..., None]
    return result


def expmap_from_matrix(matrices: FloatArray) -> FloatArray:
    """(..., 3, 3) rotation matrices to (..., 3) exponential maps with angle in [0, π]."""
    return expmap_from_quaternion(quaternion_from_matrix(matrices))


def matrix_from_expmap(expmaps: FloatArray) -> FloatArray:
    """(..., 3) exponential maps to (..., 3, 3) rotation matrices (Rodrigues' formula)."""
    return rotation_exp(expmaps)


def continuous_expmaps(matrices: FloatArray) -> FloatArray:
    """(T, J, 3, 3) rotations to (T, J, 3) exponential maps continuous along time.

    Quaternion signs are flipped so that consecutive quaternions have a non-negative dot
    product; the exponential map then stays on one branch (angles may exceed π).
    """
    quats = quaternion_from_matrix(matrices)
    if quats.shape[0] > 1:
        dots = np.sum(quats[1:] * quats[:-1], axis=-1)
        flips = np.cumprod(np.where(dots < 0.0, -1.0, 1.0), axis=0)
        quats[1:] *= flips[..., None]
    return expmap_from_quaternion(quats)


def yaw_matrix(angles: FloatArray) -> FloatArray:
    """(...,) angles in radians to (..., 3, 3) rotations about the vertical Y axis."""
    a = np.asarray(angles, dtype=np.float64)
    out = np.zeros((*a.shape, 3, 3), dtype=np.float64)
    out[..., 0, 0] = np.cos(a)
    out[..., 0, 2] = np.sin(a)
    out[..., 2, 0] = -np.sin(a)
    out[..., 2, 2] = np.cos(a)
    out[..., 1, 1] = 1.0
    return out


# -- dynamic features ---------------------------------------------------------------------
def window_matrix(frames: int) -> FloatArray:
    """Dense ``W`` (3T, T) of eq. 4, rows ordered stream-major: all statics, all Δ, all Δ²."""
    w = np.zeros((3 * frames, frames), dtype=np.float64)
    for stream, window in enumerate(WINDOWS):
        for t in range(frames):
            for offset, coefficient in window:
                w[stream * frames + t, min(max(t + offset, 0), frames - 1)] += coefficient
    return w


def observations(statics: FloatArray) -> FloatArray:
    """(T, D) static features to (T, 3D) observations ``[c, Δc, Δ²c]`` (eq. 2–3)."""
    c = np.asarray(statics, dtype=np.float64)
    frames = c.shape[0]
    streams = []
    for window in WINDOWS:
        stream = np.zeros_like(c)
        for offset, coefficient in window:
            index = np.clip(np.arange(frames) + offset, 0, frames - 1)
            stream += coefficient * c[index]
        streams.append(stream)
    return np.concatenate(streams, axis=1)

"""Maximum-likelihood parameter generation (paper eq. 10–11) and global variance (eq. 12–15).

With diagonal covariances every static dimension is independent: the static trajectory
``c`` maximising ``N(W c; μ, Σ)`` solves ``(Wᵀ Σ⁻¹ W) c = Wᵀ Σ⁻¹ μ``.  ``Wᵀ Σ⁻¹ W`` is
symmetric positive definite and banded (half bandwidth ``2 × WINDOW_REACH`` = 2), so a banded
Cholesky solve (``scipy.linalg.solveh_banded``) costs O(T) per dimension.

Global variance (Toda & Tokuda 2007): maximise ``ω log N(W c; μ, Σ) + log N(v(c); μ_v, σ_v²)``
with ``v(c)`` the per-dimension variance of ``c`` over the sequence and ``ω = 1 / (3 T)``
(HTS's weight).  Starts from the MLPG trajectory scaled to the target variance, then runs
preconditioned gradient ascent with a per-dimension backtracking step so the objective
never decreases.
"""

from __future__ import annotations

import numpy as np

from mse.extras import require
from mse.motion.hsmm.features import WINDOW_REACH, WINDOWS, FloatArray, observations

BANDS = 2 * WINDOW_REACH + 1


def _split(array: FloatArray, dims: int) -> list[FloatArray]:
    return [array[:, s * dims : (s + 1) * dims] for s in range(len(WINDOWS))]


def precision_bands(variances: FloatArray) -> FloatArray:
    """(BANDS, T, D) lower bands of ``Wᵀ Σ⁻¹ W`` per static dimension (scipy's lower form)."""
    frames, width = variances.shape
    dims = width // len(WINDOWS)
    bands = np.zeros((BANDS, frames, dims), dtype=np.float64)
    t = np.arange(frames)
    for window, variance in zip(WINDOWS, _split(variances, dims), strict=True):
        precision = 1.0 / variance
        for offset_a, coef_a in window:
            row = np.clip(t + offset_a, 0, frames - 1)
            for offset_b, coef_b in window:
                col = np.clip(t + offset_b, 0, frames - 1)
                lower = row >= col  # the symmetric pair adds the upper triangle
                np.add.at(
                    bands,
                    (row[lower] - col[lower], col[lower]),
                    coef_a * coef_b * precision[lower],
                )
    return bands


def window_transpose(streams: FloatArray) -> FloatArray:
    """``Wᵀ x`` for (T, 3D) stream-major values ``x``: back to (T, D)."""
    frames, width = streams.shape
    dims = width // len(WINDOWS)
    out = np.zeros((frames, dims), dtype=np.float64)
    t = np.arange(frames)
    for window, values in zip(WINDOWS, _split(streams, dims), strict=True):
        for offset, coefficient in window:
            np.add.at(out, np.clip(t + offset, 0, frames - 1), coefficient * values)
    return out


def mlpg(means: FloatArray, variances: FloatArray) -> FloatArray:
    """Static trajectory (T, D) from per-frame observation means and variances (T, 3D)."""
    with require("motion"):
        from scipy.linalg import solveh_banded

    means = np.asarray(means, dtype=np.float64)
    variances = np.asarray(variances, dtype=np.float64)
    bands = precision_bands(variances)
    rhs = window_transpose(means / variances)
    out = np.empty_like(rhs)
    for d in range(rhs.shape[1]):
        out[:, d] = solveh_banded(bands[:, :, d], rhs[:, d], lower=True, check_finite=False)
    return out


def mlpg_dense(means: FloatArray, variances: FloatArray) -> FloatArray:
    """Reference MLPG by a dense solve per dimension (tests only: O(T³))."""
    from mse.motion.hsmm.features import window_matrix

    frames, width = means.shape
    dims = width // len(WINDOWS)
    w = window_matrix(frames)
    out = np.empty((frames, dims), dtype=np.float64)
    for d in range(dims):
        columns = [s * dims + d for s in range(len(WINDOWS))]
        mu = means[:, columns].T.reshape(-1)  # stream-major, like W's rows
        precision = 1.0 / variances[:, columns].T.reshape(-1)
        lhs = w.T @ (precision[:, None] * w)
        out[:, d] = np.linalg.solve(lhs, w.T @ (precision * mu))
    return out


def global_variance(statics: FloatArray) -> FloatArray:
    """Per-dimension variance of a static sequence over time (eq. 12–14)."""
    values = np.asarray(statics, dtype=np.float64)
    result: FloatArray = np.var(values, axis=0)
    return result


def _objective(
    c: FloatArray,
    means: FloatArray,
    precisions: FloatArray,
    gv_mean: FloatArray,
    gv_var: FloatArray,
    weight: float,
) -> FloatArray:
    """Per-dimension GV objective (D,)."""
    residual = observations(c) - means
    dims = c.shape[1]
    hmm = -0.5 * weight * np.sum((residual**2 * precisions).reshape(-1, 3, dims), axis=(0, 1))
    gv = -0.5 * (global_variance(c) - gv_mean) ** 2 / gv_var
    result: FloatArray = hmm + gv
    return result


def generate_with_gv(
    means: FloatArray,
    variances: FloatArray,
    gv_mean: FloatArray,
    gv_var: FloatArray,
    iterations: int = 20,
) -> FloatArray:
    """MLPG followed by global-variance compensation (paper eq. 15)."""
    c = mlpg(means, variances)
    frames = c.shape[0]
    if frames < 3:
        return c
    weight = 1.0 / (len(WINDOWS) * frames)
    precisions = 1.0 / np.asarray(variances, dtype=np.float64)
    gv_mean = np.maximum(np.asarray(gv_mean, dtype=np.float64), 1e-12)
    gv_var = np.maximum(np.asarray(gv_var, dtype=np.float64), 1e-12)
    centre = c.mean(axis=0)
    current = np.maximum(global_variance(c), 1e-12)
    c = centre + (c - centre) * np.sqrt(gv_mean / current)  # variance scaling start
    diagonal = precision_bands(np.asarray(variances, dtype=np.float64))[0]
    score = _objective(c, means, precisions, gv_mean, gv_var, weight)
    step = np.ones(c.shape[1])
    for _ in range(iterations):
        centre = c.mean(axis=0)
        v = global_variance(c)
        hmm_grad = weight * (window_transpose((means - observations(c)) * precisions))
        gv_grad = -((v - gv_mean) / gv_var) * (2.0 / frames) * (c - centre)
        curvature = weight * diagonal + (4.0 / frames) * gv_mean / gv_var / frames
        direction = (hmm_grad + gv_grad) / curvature
        trial = c + step * direction
        trial_score = _objective(trial, means, precisions, gv_mean, gv_var, weight)
        better = trial_score > score
        c = np.asarray(np.where(better[None, :], trial, c), dtype=np.float64)
        score = np.where(better, trial_score, score)
        step = np.where(better, np.minimum(step * 1.5, 4.0), step * 0.5)
    return c

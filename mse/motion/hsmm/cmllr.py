"""CMLLR (Gales 1998): affine feature-space transforms, their regression blocks and their
row-by-row estimation, and refinements of a parent transform with finer blocks.

The transform is estimated in feature space, ``x̂ = A x + b``, row by row (closed form up to
a quadratic in the cofactor scale), and applied to the model as ``μ̂ = A⁻¹(μ - b)``,
``Σ̂ = A⁻¹ Σ A⁻ᵀ`` (:mod:`mse.motion.hsmm.adapt` keeps the diagonal).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mse.motion.hsmm.features import FloatArray
from mse.motion.hsmm.stats import GaussianStats


@dataclass(frozen=True, eq=False)
class AffineTransform:
    """Feature-space transform ``x̂ = A x + b``."""

    matrix: FloatArray  # (n, n)
    bias: FloatArray  # (n,)

    @staticmethod
    def identity(size: int) -> AffineTransform:
        return AffineTransform(np.eye(size), np.zeros(size))

    def apply(self, values: FloatArray) -> FloatArray:
        result: FloatArray = values @ self.matrix.T + self.bias
        return result

    def model_space(
        self, means: FloatArray, variances: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """Means and diagonal variances (rows of (K, n)) seen through the inverse transform."""
        inverse = np.linalg.inv(self.matrix)
        adapted_means = (means - self.bias) @ inverse.T
        adapted_variances = variances @ (inverse**2).T
        return adapted_means, adapted_variances


#: frames per row parameter that a regression block needs (:func:`auto_blocks`)
FRAMES_PER_PARAMETER = 2


def auto_blocks(static_dims: int, frames: int) -> str:
    """The largest regression blocks the adaptation data supports (a documented rule).

    A block of size ``k`` has ``k + 1`` parameters per row, each row estimated from every
    frame: use ``stream`` blocks (``k`` = D) when there are at least two frames per row
    parameter, else per-joint 3×3 blocks, which need only 8 frames.
    """
    return "stream" if frames >= FRAMES_PER_PARAMETER * (static_dims + 1) else "joint"


def blocks_for(static_dims: int, kind: str, root: int | None = None) -> list[np.ndarray]:
    """Index blocks of the (3D,) observation for a block-diagonal transform.

    ``root``: the static column of the root joint's first rotation component; with it, the
    static ``stream`` block leaves the root joint's three columns out, in a 3×3 block of
    their own (locomotion's adaptation, ``api.Options.root_block``). Its Δ and Δ² stay in
    their streams' blocks: the root's velocity moves with the legs' (on its own in those
    streams too, the adapted dataset 1 musical walk-back's jerk rose from 13,620 to 15,934
    cm/s³, over its 2×-real limit of 15,430; static only: 13,041).
    """
    width = 3 * static_dims
    if kind == "full":
        return [np.arange(width)]
    if kind == "stream" and root is not None:
        own = np.arange(root, root + 3)
        rest = np.setdiff1d(np.arange(static_dims), own)
        return [rest, own] + [np.arange(s * static_dims, (s + 1) * static_dims) for s in (1, 2)]
    if kind == "stream":
        return [np.arange(s * static_dims, (s + 1) * static_dims) for s in range(3)]
    if kind == "joint":
        return [
            np.arange(s * static_dims + j, s * static_dims + j + 3)
            for s in range(3)
            for j in range(0, static_dims, 3)
        ]
    raise ValueError(f"unknown regression blocks {kind!r} (full, stream, joint)")


def estimate_cmllr(
    stats: Sequence[GaussianStats],
    blocks: Sequence[np.ndarray],
    prior: float = 1.0,
    iterations: int = 4,
    centre: AffineTransform | None = None,
) -> AffineTransform:
    """Row-by-row CMLLR with a Gaussian prior of weight ``prior`` on every row, centred on
    the identity or on ``centre`` (a parent regression class's transform, as in CSMAPLR).

    Blocks of the same size have their row updates run at once.
    """
    size = stats[0].mean.shape[0]
    centre = centre if centre is not None else AffineTransform.identity(size)
    matrix = centre.matrix.copy()
    bias = centre.bias.copy()
    beta = float(sum(s.count for s in stats))
    if beta <= 0:
        return AffineTransform(matrix, bias)
    for width in sorted({len(b) for b in blocks}):
        same = np.asarray([b for b in blocks if len(b) == width])
        _estimate_blocks(stats, same, prior, iterations, centre, beta, matrix, bias)
    return AffineTransform(matrix, bias)


def _estimate_blocks(
    stats: Sequence[GaussianStats],
    index: np.ndarray,
    prior: float,
    iterations: int,
    centre: AffineTransform,
    beta: float,
    matrix: FloatArray,
    bias: FloatArray,
) -> None:
    """The rows of the blocks ``index`` (B, k), all of one size, written into ``matrix``
    and ``bias``."""
    count, k = index.shape
    counts = np.array([s.count for s in stats])
    totals = np.array([s.total for s in stats])  # (M, n)
    # Extended statistics of [1, x_block] per Gaussian and block: (M, B, k+1, k+1).
    ext = np.empty((len(stats), count, k + 1, k + 1))
    ext[:, :, 0, 0] = counts[:, None]
    ext[:, :, 0, 1:] = ext[:, :, 1:, 0] = totals[:, index]
    for m, s in enumerate(stats):
        ext[m, :, 1:, 1:] = s.scatter[index[:, :, None], index[:, None, :]]
    first = ext[:, :, 0, :]  # (M, B, k+1): [count, total]
    precision = np.array([1.0 / s.variance for s in stats])[:, index]  # (M, B, k)
    scaled = np.array([s.mean / s.variance for s in stats])[:, index]
    # Σ_m precision[m, b, i] · ext[m, b] as one batched matrix product per block.
    flat = ext.transpose(1, 0, 2, 3).reshape(count, len(stats), (k + 1) ** 2)
    g = np.matmul(precision.transpose(1, 2, 0), flat).reshape(count, k, k + 1, k + 1)
    g += prior * np.eye(k + 1)
    kvec = np.einsum("mbi,mbx->bix", scaled, first)
    # Rows [b, A] of the prior's centre, block by block; the iterations start from them.
    rows = np.concatenate(
        [centre.bias[index][:, :, None], centre.matrix[index[:, :, None], index[:, None, :]]],
        axis=2,
    )
    kvec += prior * rows
    g_inv = np.linalg.inv(g)  # (B, k, k+1, k+1)
    gk = np.matmul(g_inv, kvec[:, :, :, None])[:, :, :, 0]  # (B, k, k+1): G⁻¹k per row
    inverse = np.linalg.inv(rows[:, :, 1:])  # (B, k, k), kept current by rank-one updates
    for _ in range(iterations):
        for r in range(k):
            cofactor = np.zeros((count, k + 1))
            cofactor[:, 1:] = inverse[:, :, r]
            kr = kvec[:, r]
            # G is symmetric: G⁻¹c and G⁻¹k give every term without further products, and
            # w G wᵀ = w · (αc + k) because w = (αc + k) G⁻¹.
            gc = np.matmul(g_inv[:, r], cofactor[:, :, None])[:, :, 0]
            a = np.sum(cofactor * gc, axis=1)
            b = np.sum(kr * gc, axis=1)
            root = np.sqrt(b * b + 4.0 * a * beta)
            best = rows[:, r].copy()
            best_score = np.full(count, -np.inf)
            for alpha in ((-b + root) / (2.0 * a), (-b - root) / (2.0 * a)):
                w = alpha[:, None] * gc + gk[:, r]
                det_term = np.abs(np.sum(cofactor * w, axis=1))
                score = (
                    beta * np.log(np.maximum(det_term, 1e-300))
                    - 0.5 * np.sum(w * (alpha[:, None] * cofactor + kr), axis=1)
                    + np.sum(w * kr, axis=1)
                )
                better = (score > best_score) & (det_term > 0)
                best[better] = w[better]
                best_score = np.where(better, score, best_score)
            # Sherman-Morrison for A' = A + e_r δᵀ:
            # A'⁻¹ = A⁻¹ - (A⁻¹ e_r)(δᵀ A⁻¹) / (1 + δᵀ A⁻¹ e_r).
            delta = best[:, 1:] - rows[:, r, 1:]
            column = inverse[:, :, r].copy()
            row = np.matmul(delta[:, None, :], inverse)[:, 0]
            denominator = 1.0 + np.sum(delta * column, axis=1)
            inverse -= column[:, :, None] * row[:, None, :] / denominator[:, None, None]
            rows[:, r] = best
    for block, block_rows in zip(index, rows, strict=True):
        matrix[np.ix_(block, block)] = block_rows[:, 1:]
        bias[block] = block_rows[:, 0]


def transformed_stats(stats: GaussianStats, transform: AffineTransform) -> GaussianStats:
    """The statistics of the data seen through ``transform`` (``y = A x + b``), against the
    same Gaussian."""
    a, b = transform.matrix, transform.bias
    total = a @ stats.total
    moved = total + stats.count * b
    scatter = a @ stats.scatter @ a.T + np.outer(total, b) + np.outer(b, total) + stats.count * np.outer(b, b)
    return GaussianStats(stats.count, moved, scatter, stats.mean, stats.variance)


def estimate_refinement(
    stats: Sequence[GaussianStats], blocks: Sequence[np.ndarray], prior: float, parent: AffineTransform
) -> AffineTransform:
    """A transform with finer blocks than its parent's, estimated on the data the parent
    has transformed (prior centred on the identity) and composed with it: ``A_c (A_p x +
    b_p) + b_c``. Centred on the parent directly, the finer blocks would be estimated as if
    the parent's entries outside them were zero, yet kept them (the adapted Bandai dataset 2
    elderly wave then held its hands at the hips: static means 0.61 rad from the take's
    where the average model's are 0.13 away)."""
    child = estimate_cmllr([transformed_stats(s, parent) for s in stats], blocks, prior)
    return AffineTransform(child.matrix @ parent.matrix, child.matrix @ parent.bias + child.bias)

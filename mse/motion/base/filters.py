"""Small numerical helpers in plain numpy, so that the LMA features need no scipy import
(``scipy.signal`` alone takes seconds to import on a loaded machine).

- :func:`zero_phase_lowpass`: Butterworth order 2 applied forwards and backwards, the same
  result as ``scipy.signal.filtfilt(b, a, x, axis=0)`` with its default odd padding and
  steady-state initial conditions. The filter is linear, so it is computed once per
  (length, frame time, cut-off) as an N x N matrix (cached) and applied by one product.
- :func:`convex_hull_area`: area of the 2-D convex hull (Akl-Toussaint pre-filter, then
  Andrew's monotone chain).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from mse.motion.base.kinematics import FloatArray


def butterworth2(cutoff_hz: float, frame_time: float) -> tuple[tuple[float, float, float], float, float]:
    """``(b0, b1, b2), a1, a2`` of a second-order low-pass Butterworth (bilinear transform)."""
    nyquist = 0.5 / frame_time
    cutoff = min(cutoff_hz, 0.8 * nyquist)
    k = math.tan(math.pi * cutoff * frame_time)
    norm = 1.0 / (1.0 + math.sqrt(2.0) * k + k * k)
    b0 = k * k * norm
    a1 = 2.0 * (k * k - 1.0) * norm
    a2 = (1.0 - math.sqrt(2.0) * k + k * k) * norm
    return (b0, 2.0 * b0, b0), a1, a2


def _one_pass(x: FloatArray, b: tuple[float, float, float], a1: float, a2: float) -> FloatArray:
    """Direct form II transposed along axis 0, started in the steady state of x[0]."""
    b0, b1, b2 = b
    z1 = (1.0 - b0) * x[0]
    z2 = (b2 - a2) * x[0]
    out = np.empty_like(x)
    for n in range(len(x)):
        y = b0 * x[n] + z1
        z1 = b1 * x[n] - a1 * y + z2
        z2 = b2 * x[n] - a2 * y
        out[n] = y
    return out


_MATRIX_LIMIT = 512  # longer signals are filtered sample by sample (memory: N x N floats)


def _filtfilt_direct(x: FloatArray, frame_time: float, cutoff_hz: float) -> FloatArray:
    b, a1, a2 = butterworth2(cutoff_hz, frame_time)
    pad = min(9, len(x) - 1)
    head = 2.0 * x[:1] - x[pad:0:-1]
    tail = 2.0 * x[-1:] - x[-2 : -pad - 2 : -1]
    extended = np.concatenate([head, x, tail])
    forward = _one_pass(extended, b, a1, a2)
    backward = _one_pass(forward[::-1], b, a1, a2)[::-1]
    return np.ascontiguousarray(backward[pad : pad + len(x)])


@functools.lru_cache(maxsize=32)
def _filter_matrix(length: int, frame_time: float, cutoff_hz: float) -> FloatArray:
    b, a1, a2 = butterworth2(cutoff_hz, frame_time)
    pad = min(9, length - 1)  # scipy's default padlen for order 2 is 3 * 3
    identity = np.eye(length)
    # odd extension at both ends, as scipy.signal.filtfilt does
    head = 2.0 * identity[:1] - identity[pad:0:-1]
    tail = 2.0 * identity[-1:] - identity[-2 : -pad - 2 : -1]
    extended = np.vstack([head, identity, tail])
    forward = _one_pass(extended, b, a1, a2)
    backward = _one_pass(forward[::-1], b, a1, a2)[::-1]
    matrix: FloatArray = np.ascontiguousarray(backward[pad : pad + length])
    return matrix


def zero_phase_lowpass(signal: FloatArray, frame_time: float, cutoff_hz: float) -> FloatArray:
    """Zero-phase Butterworth (order 2) low-pass along axis 0; short signals pass unchanged."""
    length = len(signal)
    if length < 4:
        return signal
    if length > _MATRIX_LIMIT:
        return _filtfilt_direct(signal, frame_time, cutoff_hz)
    matrix = _filter_matrix(length, round(frame_time, 12), cutoff_hz)
    flat = signal.reshape(length, -1)
    filtered: FloatArray = (matrix @ flat).reshape(signal.shape)
    return filtered


def convex_hull_area(points: FloatArray) -> float:
    """Area of the convex hull of (N, 2) points (0 for fewer than three distinct points)."""
    if len(points) < 3:
        return 0.0
    # Akl-Toussaint: drop the points inside the quadrilateral of the four extreme points
    extremes = points[
        [
            int(np.argmin(points[:, 0])),
            int(np.argmin(points[:, 1])),
            int(np.argmax(points[:, 0])),
            int(np.argmax(points[:, 1])),
        ]
    ]
    inside = np.ones(len(points), dtype=bool)
    for start, stop in zip(extremes, np.roll(extremes, -1, axis=0), strict=True):
        edge = stop - start
        cross = edge[0] * (points[:, 1] - start[1]) - edge[1] * (points[:, 0] - start[0])
        inside &= cross > 1e-12
    candidates = np.unique(points[~inside], axis=0)
    if len(candidates) < 3:
        return 0.0
    ordered = sorted(map(tuple, candidates.tolist()))

    def half(sequence: list[tuple[float, float]]) -> list[tuple[float, float]]:
        chain: list[tuple[float, float]] = []
        for p in sequence:
            while len(chain) >= 2:
                (ox, oy), (ax, ay) = chain[-2], chain[-1]
                if (ax - ox) * (p[1] - oy) - (ay - oy) * (p[0] - ox) > 0:
                    break
                chain.pop()
            chain.append(p)
        return chain

    hull = half(ordered)[:-1] + half(ordered[::-1])[:-1]
    if len(hull) < 3:
        return 0.0
    xs = np.array([p[0] for p in hull])
    ys = np.array([p[1] for p in hull])
    return float(0.5 * abs(np.dot(xs, np.roll(ys, -1)) - np.dot(ys, np.roll(xs, -1))))

"""Longer clips by repetition: a cycling movement generated at its own length, its cycles
repeated at their own tempo to fill a longer request (rather than stretched).

Both methods generate a standing cycle (a wave) at the length of their training clips; a
request for three times that drew the same swings three times slower (Bandai dataset 2
feminine waves, LMA + HMM: wave amplitude 7.3 cm at the real length, 1.9 at 3x, the real
takes 7.2-8.2). :func:`looped` finds in the generated trajectory the stretch between two
frames whose poses and velocities agree best for its length (at least :data:`MIN_LOOP_SHARE`
of the clip apart, the start within its first half, the end within its second: the rise and
the fall stay once), plays the clip up to its end, back to its start as many times as the request
holds, then the rest of the clip; the remainder (under half a loop) is absorbed by a
slight resampling. At each join the repetition starts where the clip would have gone on and
eases into its own frames over :data:`BLEND_S`. An action that does not cycle is played at
its own tempo and then rests in its last pose (:func:`held`): stretched to three times its
length, a Bandai dataset 1 kick lost its dip (head dip under the real range, both methods).
"""

from __future__ import annotations

import numpy as np

from mse.motion.base.kinematics import FloatArray

__all__ = ["BLEND_S", "EDGE_SHARE", "MIN_LOOP_SHARE", "held", "loop_span", "looped"]

#: the repeated stretch spans at least this share of the clip
MIN_LOOP_SHARE = 0.3
#: a standing cycle's repeated stretch starts after this share of the clip (its rise); a
#: travelling one's anywhere (a Bandai run's clip holds about one cycle of its steps)
EDGE_SHARE = 0.1
#: a loop spans a whole number of the action's periods within this share of one
PERIOD_TOLERANCE = 0.15
#: each repetition eases from where the clip would have gone on into its own frames over this
#: long (s)
BLEND_S = 0.2


def loop_span(values: FloatArray, edge: float = EDGE_SHARE, period: float = 0.0) -> tuple[int, int]:
    """``(start, end)`` of the stretch of ``values`` (T, D) to repeat: the pair of frames,
    ``start`` in the first half (after its first ``edge`` share: the rise) and ``end`` in the second,
    at least :data:`MIN_LOOP_SHARE` of the clip apart, whose values and frame-to-frame
    changes differ least (each dimension scaled by its spread), per frame of the stretch;
    with a ``period`` (frames, the action's cycle measured on its clips), a whole number of
    periods (within :data:`PERIOD_TOLERANCE`): half a cycle of steps swaps the legs."""
    frames = len(values)
    scale = np.maximum(values.std(axis=0), 1e-9)
    x = values / scale
    v = np.gradient(x, axis=0) * 4.0
    starts = np.arange(max(1, int(edge * frames)), frames // 2)
    ends = np.arange(frames // 2, frames - 1)
    if not len(starts) or not len(ends):
        return 0, frames
    gap = ends[None, :] - starts[:, None]
    cost = np.sum((x[starts][:, None] - x[ends][None]) ** 2, axis=-1) + np.sum(
        (v[starts][:, None] - v[ends][None]) ** 2, axis=-1
    )
    cost = cost * frames / np.maximum(gap, 1)  # the longer of two equal joins: more of the cycle
    cost[gap < MIN_LOOP_SHARE * frames] = np.inf
    if period > 0:
        cycles = np.maximum(np.round(gap / period), 1.0)
        cost[np.abs(gap - cycles * period) > PERIOD_TOLERANCE * period] = np.inf
    if not np.isfinite(cost).any():
        return 0, frames
    i, j = np.unravel_index(int(np.argmin(cost)), cost.shape)
    return int(starts[i]), int(ends[j])


def looped(
    values: FloatArray,
    frames: int,
    frame_time: float,
    edge: float = EDGE_SHARE,
    period_s: float = 0.0,
    stretch: tuple[int, int] | None = None,
) -> FloatArray:
    """``values`` (T, D) lasting ``frames`` frames: its loop (:func:`loop_span`, or ``stretch``
    when the caller knows where its cycles are) repeated as often as fits, then resampled to
    exactly ``frames``. Unchanged when ``frames`` is not longer than the clip by at least half
    a loop."""
    total = len(values)
    start, end = stretch if stretch is not None else loop_span(values, edge, period_s / frame_time)
    span = end - start
    repeats = round((frames - total) / span) if span > 0 else 0
    if repeats <= 0:
        return values
    blend = max(2, round(BLEND_S / frame_time))
    # each repetition starts where the clip would have gone on (``values[end]``) and eases
    # into its own frames over ``blend`` frames (a cosine ramp of the difference)
    ramp = 0.5 * (1.0 + np.cos(np.pi * np.arange(blend) / blend))[:, None]
    offset = values[min(end, total - 1)] - values[start]
    pieces = [values[:end]]
    for index in range(repeats):
        piece = (values[start:end] if index < repeats - 1 else values[start:]).copy()
        width = min(blend, len(piece))
        piece[:width] += ramp[:width] * offset
        pieces.append(piece)
    out = np.concatenate(pieces)
    if len(out) == frames:
        return out
    source = np.linspace(0.0, 1.0, len(out))
    target = np.linspace(0.0, 1.0, frames)
    result = np.empty((frames, values.shape[1]))
    for dim in range(values.shape[1]):
        result[:, dim] = np.interp(target, source, out[:, dim])
    return result


def held(values: FloatArray, frames: int) -> FloatArray:
    """``values`` (T, D) followed by its last frame held, ``frames`` frames in all (the
    clip's own tempo, then its rest pose); unchanged when not longer than the clip."""
    if frames <= len(values):
        return values
    return np.vstack([values, np.repeat(values[-1:], frames - len(values), axis=0)])

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
A request shorter than one cycle (:func:`shorter_than_a_cycle`; an action that does not cycle:
shorter than its clip) starts the clip at its own tempo and eases into its rest pose
(:func:`rested`) rather than stopping mid-swing or playing the whole action faster.
"""

from __future__ import annotations

import numpy as np

from mse.motion.base.kinematics import FloatArray, rotation_exp, rotation_log

__all__ = [
    "BLEND_S",
    "EDGE_SHARE",
    "MIN_LOOP_SHARE",
    "REST_EASE_S",
    "held",
    "loop_span",
    "looped",
    "rest_ease_frames",
    "rested",
    "rested_facing",
    "shorter_than_a_cycle",
]

#: the repeated stretch spans at least this share of the clip
MIN_LOOP_SHARE = 0.3
#: a standing cycle's repeated stretch starts after this share of the clip (its rise); a
#: travelling one's anywhere (a Bandai run's clip holds about one cycle of its steps)
EDGE_SHARE = 0.1
#: a loop spans a whole number of the action's periods within this share of one
PERIOD_TOLERANCE = 0.15
#: a request shorter than one cycle eases into the clip's rest pose over its last this long (s),
#: or the whole of a shorter request: over 0.3 s, at most half the request, a Bandai dataset 1
#: byebye at 0.3 of its take had 5.5x its take's jerk (now 0.8x), a walk at 0.6 of its cycle 2.0x (1.1x)
REST_EASE_S = 1.0
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
    ending: bool = True,
    stretch: tuple[int, int] | None = None,
) -> FloatArray:
    """``values`` (T, D) lasting ``frames`` frames: its loop (:func:`loop_span`, or ``stretch``
    when the caller knows where its cycles are) repeated as often as fits, then resampled to
    exactly ``frames``. Unchanged when ``frames`` is not longer than the clip by at least half
    a loop. ``ending=False`` (a travelling cycle, which has no rise and fall to keep): the loop
    repeats until ``frames`` are filled, the last repetition cut, at the clip's own tempo (no
    resampling: a Bandai dataset 1 run of 24 frames at 3x was played 12 % faster to fit, its
    jerk 1.4x)."""
    total = len(values)
    start, end = stretch if stretch is not None else loop_span(values, edge, period_s / frame_time)
    span = end - start
    if not ending and span > 0 and frames > total:
        repeats = -(-(frames - end) // span)  # whole loops and the last one cut
    else:
        repeats = round((frames - total) / span) if span > 0 else 0
    if repeats <= 0:
        return values
    pieces = [values[:end]]
    for index in range(repeats):
        last = index == repeats - 1 and ending
        pieces.append(values[start:] if last else values[start:end])
    out = _joined(pieces, values[min(end, total - 1)] - values[start], max(2, round(BLEND_S / frame_time)))
    if not ending and len(out) >= frames:
        return out[:frames]
    if len(out) == frames:
        return out
    source = np.linspace(0.0, 1.0, len(out))
    target = np.linspace(0.0, 1.0, frames)
    result = np.empty((frames, values.shape[1]))
    for dim in range(values.shape[1]):
        result[:, dim] = np.interp(target, source, out[:, dim])
    return result


def _joined(pieces: list[FloatArray], gap: FloatArray, blend: int) -> FloatArray:
    """``pieces`` one after the other, each join (where the clip would have gone on by
    ``gap`` more than the next piece starts) eased across: the gap is spread over ``blend``
    frames before the join and ``blend`` after along a minimum-jerk curve, half on either
    side (the pose, its velocity and acceleration stay continuous)."""
    out = np.concatenate(pieces).copy()
    joins = np.cumsum([len(p) for p in pieces])[:-1]
    steps = np.arange(-blend, blend)
    share = (steps + blend + 0.5) / (2 * blend)
    smooth = share**3 * (10.0 - 15.0 * share + 6.0 * share**2)  # 0 -> 1, minimum jerk
    for join in joins:
        # the pieces as if the clip went on across the join (the gap removed after it), then
        # the gap eased in: before the join it is added up to half, after it removed from half
        frames = join + steps
        inside = (frames >= 0) & (frames < len(out))
        correction = smooth - (steps >= 0)
        out[frames[inside]] += correction[inside, None] * -gap
    return out


def held(values: FloatArray, frames: int) -> FloatArray:
    """``values`` (T, D) followed by its last frame held, ``frames`` frames in all (the
    clip's own tempo, then its rest pose); unchanged when not longer than the clip."""
    if frames <= len(values):
        return values
    return np.vstack([values, np.repeat(values[-1:], frames - len(values), axis=0)])


def shorter_than_a_cycle(frames: int, clip_frames: int, frame_time: float, period_s: float) -> bool:
    """Whether a request of ``frames`` cannot hold one cycle of an action whose clip (as
    generated at its own length) has ``clip_frames``: shorter than the clip and than the
    action's period ``period_s`` (measured on its clips; 0 for an action that does not cycle,
    whose one cycle is the clip)."""
    cycle_s = period_s if period_s > 0 else clip_frames * frame_time
    return frames < clip_frames and frames * frame_time < cycle_s


def rest_ease_frames(frames: int, frame_time: float) -> int:
    """How many frames :func:`rested` eases a request of ``frames`` into its rest pose over:
    :data:`REST_EASE_S`, or all but the first frame of a shorter request (at least 2)."""
    return max(2, min(frames - 1, round(REST_EASE_S / frame_time)))


def _twist(vectors: FloatArray, up: FloatArray) -> FloatArray:
    """(T, 3) rotation vectors as swing-twist features: the swing (a rotation vector
    perpendicular to the unit ``up``) plus the twist about ``up``, unwrapped along time, along
    ``up``. The twist is a scalar with no shell at a whole turn, where a rotation vector's
    direction changes in a few frames."""
    angles = np.linalg.norm(vectors, axis=-1)
    safe = np.where(angles < 1e-12, 1.0, angles)
    along = np.where(angles < 1e-12, 0.0, np.sin(0.5 * angles) * (vectors @ up) / safe)
    yaws = np.unwrap(2.0 * np.arctan2(along, np.cos(0.5 * angles)))
    swing = rotation_log(rotation_exp(-yaws[:, None] * up[None, :]) @ rotation_exp(vectors))
    result: FloatArray = swing + (yaws - swing @ up)[:, None] * up[None, :]
    return result


def _untwist(features: FloatArray, up: FloatArray) -> FloatArray:
    """Inverse of :func:`_twist`."""
    yaws = features @ up
    swing = features - yaws[:, None] * up[None, :]
    result: FloatArray = rotation_log(rotation_exp(yaws[:, None] * up[None, :]) @ rotation_exp(swing))
    return result


def rested_facing(values: FloatArray, frames: int, frame_time: float, root: slice, up: FloatArray) -> FloatArray:
    """:func:`rested` for a path whose ``root`` columns are the root joint's rotation vector:
    the body rests facing where it faces when the ease starts (its twist about the unit
    ``up``, in the root's frame, held; the swing, its lean or bow, eased into the rest's). The
    Bandai dataset 1 kick spins three full turns; eased into its last heading through the
    rotation vectors, the body turned 106 degrees in 3 frames."""
    if frames >= len(values):
        return values
    twisted = values.copy()
    twisted[:, root] = _twist(values[:, root], up)
    rest = twisted[-1].copy()
    start = twisted[max(0, frames - rest_ease_frames(frames, frame_time) - 1), root]
    rest[root] += (float(start @ up) - float(rest[root] @ up)) * up
    out = rested(twisted, frames, frame_time, rest)
    out[:, root] = _untwist(out[:, root], up)
    return out


def rested(values: FloatArray, frames: int, frame_time: float, rest: FloatArray | None = None) -> FloatArray:
    """The first ``frames`` frames of ``values`` (T, D) ending on its rest pose (``rest``,
    default its last frame, where the take ends): a request shorter than one cycle of the
    action starts it at its own tempo and, over the last :func:`rest_ease_frames`, eases into
    the rest pose along a minimum-jerk curve (whose weight starts flat: the first frames are the
    clip's own), rather than stopping mid-swing. The ease reaches
    the rest pose one frame before the end, so the last frame is still: eased into the last
    frame itself, a 7-frame request of a Bandai dataset 1 run (0.3 of its cycle) ended at 290
    cm/s. Unchanged when ``frames`` is not shorter than the clip."""
    if frames >= len(values):
        return values
    out = values[: max(frames, 2)].copy()
    ease = rest_ease_frames(frames, frame_time)
    share = np.minimum(np.arange(1, ease + 1) / (ease - 1), 1.0)
    weight = (share**3 * (10.0 - 15.0 * share + 6.0 * share**2))[:, None]
    out[-ease:] = (1.0 - weight) * out[-ease:] + weight * (values[-1] if rest is None else rest)
    return out

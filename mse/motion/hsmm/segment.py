"""Unit segmentation: steps of cyclic actions, one unit for one-shot actions.

The paper segments walks by hand into left and right steps at heel strikes (§4) and labels
each step with its position in the sequence.  Here the boundaries are found automatically:
the signed distance between the two feet along the (aligned) forward axis peaks at each
heel strike (double support, one foot furthest in front), so its alternating extrema are
the step boundaries.  Units are named ``{context}-{leg}`` with context ``first`` (start-up
to the first strike), ``inner``, ``last`` (last strike to the end) and leg ``a``/``b``
(the leg that swings).  One-shot actions are a single unit ``whole``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mse.motion.hsmm.features import FloatArray

#: Actions modelled as cycles of steps (Bandai dataset 1 contents); others are one-shot.
CYCLIC_ACTIONS = frozenset({"walk", "run", "dash", "walk-back", "walk-left", "walk-right"})
ONE_SHOT_UNIT = "whole"


@dataclass(frozen=True, slots=True)
class Segment:
    """One unit instance: frames ``[start, stop)`` of a clip."""

    unit: str
    start: int
    stop: int

    @property
    def length(self) -> int:
        return self.stop - self.start


def foot_separation(
    positions: FloatArray, contacts: tuple[tuple[int, ...], tuple[int, ...]]
) -> FloatArray:
    """Forward (+Z, after alignment) distance of foot a in front of foot b, per frame."""
    foot_a = positions[:, contacts[0][0], 2]
    foot_b = positions[:, contacts[1][0], 2]
    result: FloatArray = foot_a - foot_b
    return result


def step_boundaries(separation: FloatArray, min_gap: int) -> list[int]:
    """Frames of alternating extrema of the foot separation (heel strikes)."""
    from scipy.signal import find_peaks

    x = np.asarray(separation, dtype=np.float64)
    if x.size < 3:
        return []
    centred = x - np.median(x)
    amplitude = float(np.percentile(np.abs(centred), 90))
    if amplitude <= 1e-9:
        return []
    prominence = 0.5 * amplitude
    front, _ = find_peaks(centred, distance=min_gap, prominence=prominence)
    back, _ = find_peaks(-centred, distance=min_gap, prominence=prominence)
    events = sorted([(int(i), 1) for i in front] + [(int(i), -1) for i in back])
    strikes: list[tuple[int, int]] = []
    for frame, side in events:
        if centred[frame] * side < 0.3 * amplitude:
            continue  # an extremum on the wrong side of the median is not a strike
        if strikes and strikes[-1][1] == side:
            # Two strikes of the same foot in a row: keep the larger one.
            if abs(centred[frame]) > abs(centred[strikes[-1][0]]):
                strikes[-1] = (frame, side)
            continue
        strikes.append((frame, side))
    return [frame for frame, _ in strikes]


def segment_clip(
    frames: int,
    cyclic: bool,
    separation: FloatArray | None = None,
    min_unit: int = 5,
    min_gap: int = 6,
) -> list[Segment]:
    """Unit instances covering ``[0, frames)``; every instance has at least ``min_unit`` frames."""
    if not cyclic or separation is None:
        return [Segment(ONE_SHOT_UNIT, 0, frames)]
    strikes = [
        s for s in step_boundaries(separation, min_gap) if min_unit <= s <= frames - min_unit
    ]
    if not strikes:
        return [Segment(ONE_SHOT_UNIT, 0, frames)]
    bounds = [0, *strikes, frames]
    # The swing leg of the step ending at a strike is the one in front at that strike.
    legs = ["a" if separation[s] > np.median(separation) else "b" for s in strikes]
    legs.append("b" if legs[-1] == "a" else "a")
    segments = []
    last = len(bounds) - 2
    for index in range(len(bounds) - 1):
        context = "first" if index == 0 else "last" if index == last else "inner"
        segments.append(Segment(f"{context}-{legs[index]}", bounds[index], bounds[index + 1]))
    return [s for s in segments if s.length >= 1]

"""Unit segmentation: steps of cyclic actions, one unit for one-shot actions.

The paper segments walks by hand into left and right steps at heel strikes (§4) and labels
each step with its position in the sequence.  Here the boundaries are found automatically:
the signed distance between the two feet along the (aligned) forward axis peaks at each
heel strike (double support, one foot furthest in front), so its alternating extrema are
the step boundaries.  Units are named ``{context}-{leg}`` with context ``first`` (start-up
to the first strike), ``inner``, ``last`` (last strike to the end) and leg ``a``/``b``
(the leg that swings); waves also label the unit after the first ``second``.  One-shot
actions are a single unit ``whole``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mse.extras import require
from mse.motion.hsmm.features import FloatArray

#: Actions modelled as cycles of steps (Bandai dataset 1 contents).
LOCOMOTION = frozenset({"walk", "run", "dash", "walk-back", "walk-left", "walk-right"})
#: Actions done standing but made of repeated half-cycles of the hands (Bandai dataset 2's
#: wave): one unit per swing of the hands from one side to the other, cut at the turns of
#: :func:`hand_sway` as steps are cut at heel strikes. As one ``whole`` unit, the takes'
#: waves (3-12 swings, in different phases) were averaged state by state into a blur: the
#: generated waves of three styles swung 3.4-5.2 cm where the real ones swing 5.5-50.
HAND_CYCLE_ACTIONS = frozenset({"wave-both-hands"})
#: Actions whose unit after the first is a context of its own, ``second`` (HTS gives a
#: unit's duration the context of its neighbours). A wave's first unit raises the hands
#: to a turn of the sway, often flared outward, and the next one comes back from that
#: turn: in Bandai dataset 2 it lasts 9-11 frames in all six feminine takes, where the
#: feminine ``inner`` units last 5-166 (holds with 1-2 cm ripples). Labelled ``inner``,
#: the return shared one duration distribution with the holds, and the adapted feminine
#: wave came back from its flare in about 25 frames where the take takes 10.
SECOND_CONTEXT_ACTIONS = HAND_CYCLE_ACTIONS
#: Actions modelled as cycles of units; the others are one-shot (one unit ``whole``).
CYCLIC_ACTIONS = LOCOMOTION | HAND_CYCLE_ACTIONS
ONE_SHOT_UNIT = "whole"
#: the hands' side-to-side position is detrended by its moving average over this long (s)
SWAY_DETREND_S = 1.0


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


def hand_sway(positions: FloatArray, hands: tuple[int, int], chest: int, frame_time: float) -> FloatArray:
    """Side-to-side (X, after alignment) position of the hand that sways most, against the
    chest, minus its moving average over :data:`SWAY_DETREND_S` (raising and lowering the
    arms is not a swing): its alternating extrema are the turns of a wave."""
    relative = positions[:, list(hands), 0] - positions[:, [chest], 0]
    window = max(3, round(SWAY_DETREND_S / frame_time) | 1)
    kernel = np.ones(window) / window
    detrended = np.empty_like(relative)
    for k in range(relative.shape[1]):
        padded = np.pad(relative[:, k], (window // 2, window // 2), mode="edge")
        detrended[:, k] = relative[:, k] - np.convolve(padded, kernel, mode="valid")
    result: FloatArray = detrended[:, int(np.argmax(detrended.std(axis=0)))]
    return result


def step_boundaries(separation: FloatArray, min_gap: int) -> list[int]:
    """Frames of alternating extrema of the foot separation (heel strikes)."""
    with require("motion"):
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
    second: bool = False,
) -> list[Segment]:
    """Unit instances covering ``[0, frames)``; every instance has at least ``min_unit`` frames.

    ``second``: the unit after the first, unless it is the last, has the context ``second``
    instead of ``inner`` (see :data:`SECOND_CONTEXT_ACTIONS`).
    """
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
        if second and index == 1 and context == "inner":
            context = "second"
        segments.append(Segment(f"{context}-{legs[index]}", bounds[index], bounds[index + 1]))
    return [s for s in segments if s.length >= 1]

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

from mse.motion.base.cycles import detrended_sway, step_boundaries
from mse.motion.hsmm.features import FloatArray

#: Which actions cycle and by which limbs is measured from their clips
#: (:func:`mse.motion.base.cycles.action_shape`). Hand cycles (waves) are cut into one unit per
#: swing of the hands from one side to the other, at the turns of :func:`hand_sway`, as steps
#: are cut at heel strikes. As one ``whole`` unit, the takes' waves (3-12 swings, in different
#: phases) were averaged state by state into a blur: the generated waves of three styles swung
#: 3.4-5.2 cm where the real ones swing 5.5-50.
#:
#: A hand cycle's unit after the first is a context of its own, ``second`` (HTS gives a unit's
#: duration the context of its neighbours). A wave's first unit raises the hands to a turn of
#: the sway, often flared outward, and the next one comes back from that turn: in Bandai
#: dataset 2 it lasts 9-11 frames in all six feminine takes, where the feminine ``inner`` units
#: last 5-166 (holds with 1-2 cm ripples). Labelled ``inner``, the return shared one duration
#: distribution with the holds, and the adapted feminine wave came back from its flare in about
#: 25 frames where the take takes 10.
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


def hand_sway(positions: FloatArray, hands: tuple[int, int], chest: int, frame_time: float) -> FloatArray:
    """Side-to-side (X, after alignment) position of the hand that sways most, against the
    chest, detrended (:func:`mse.motion.base.cycles.detrended_sway`): its alternating extrema
    are the turns of a wave."""
    return detrended_sway(positions[:, list(hands), 0] - positions[:, [chest], 0], frame_time)


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
    instead of ``inner`` (hand cycles; see the comment on :data:`ONE_SHOT_UNIT`).
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

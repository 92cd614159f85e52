"""Unit instances of clips: segmentation into units in context, and their observations.

A cyclic clip is cut at the alternating extrema of its cycle signal (the feet's forward
separation for steps, the hands' sway for waves, :mod:`mse.motion.hsmm.segment`); each unit
instance starts with equal state splits. Split out of :mod:`mse.motion.hsmm.api`, which
re-exports these names.
"""

from __future__ import annotations

from collections.abc import Sequence

from mse.motion.base.bvh import Motion
from mse.motion.base.cycles import CycleKind
from mse.motion.hsmm.carried import clip_carried
from mse.motion.hsmm.features import FloatArray, observations
from mse.motion.hsmm.model import Instance, uniform_bounds
from mse.motion.hsmm.prep import Template, pose_positions, static_features
from mse.motion.hsmm.segment import (
    ONE_SHOT_UNIT,
    Segment,
    foot_separation,
    hand_sway,
    segment_clip,
)

__all__ = [
    "Segmentation",
    "clip_instances",
    "cycle_signal",
    "gather_instances",
    "segment_motion",
]


def cycle_signal(statics: FloatArray, template: Template, cycle: CycleKind = "steps") -> FloatArray:
    """The signal whose alternating extrema cut a clip into units: the feet's forward
    separation (steps), or for a hand cycle the hands' sway."""
    positions = pose_positions(statics, template)
    if cycle == "hands":
        from mse.motion.base.bodyparts import body_map

        body = body_map(template.skeleton)
        return hand_sway(positions, (body.left_hand, body.right_hand), body.torso, template.frame_time)
    return foot_separation(positions, template.contacts)


def _segments(frames: int, cycle: CycleKind, signal: FloatArray | None) -> list[Segment]:
    return segment_clip(frames, cycle != "none", signal, second=cycle == "hands")


def segment_motion(motion: Motion, template: Template, cycle: CycleKind) -> list[Segment]:
    """The unit segments of a complete clip (steps in context, the hands' swings for a hand
    cycle, one unit for a one-shot action)."""
    statics = static_features(motion, template)
    cyclic = cycle != "none"
    separation = cycle_signal(statics, template, cycle) if cyclic else None
    return _segments(statics.shape[0], cycle, separation)


#: Unit segments per clip, e.g. from a hand labelling or from :func:`segment_motion` on a
#: whole take when only some of its steps are used; None: found automatically.
Segmentation = Sequence[Sequence[Segment] | None] | None


def clip_instances(
    motion: Motion,
    style: str,
    template: Template,
    cycle: CycleKind,
    states: int,
    segments: Sequence[Segment] | None = None,
) -> tuple[list[Instance], FloatArray]:
    """Unit instances of one clip (equal state splits) and its static features.

    With ``segments`` (labelled frame ranges of the clip), only those frames are used and
    the static features returned are those of the frames they span. ``cycle`` selects the
    cycle signal (:func:`cycle_signal`) and whether flight phases are learnt (steps).
    """
    statics = static_features(motion, template)
    obs = observations(statics)
    cyclic = cycle != "none"
    if segments is None:
        separation = cycle_signal(statics, template, cycle) if cyclic else None
        segments = _segments(statics.shape[0], cycle, separation)
    elif segments:
        for segment in segments:
            if not 0 <= segment.start < segment.stop <= statics.shape[0]:
                raise ValueError(
                    f"segment {segment.unit} [{segment.start}, {segment.stop}) is outside the "
                    f"clip's {statics.shape[0]} frames"
                )
        statics = statics[min(s.start for s in segments) : max(s.stop for s in segments)]
    carried = clip_carried(motion, template) if cycle == "steps" else None
    instances = [
        Instance(
            s.unit,
            style,
            obs[s.start : s.stop],
            uniform_bounds(s.length, states),
            carried[s.start : s.stop] if carried is not None else None,
        )
        for s in segments
        if s.length >= states
    ]
    return instances, statics


def gather_instances(
    clips: Sequence[tuple[Motion, str]],
    template: Template,
    cycle: CycleKind,
    states: int,
    segmentation: Segmentation = None,
) -> tuple[list[Instance], list[FloatArray]]:
    """The unit instances of every clip and each clip's static features (clips without
    steps are dropped from a cyclic action's data)."""
    instances: list[Instance] = []
    statics: list[FloatArray] = []
    if segmentation is not None and len(segmentation) != len(clips):
        raise ValueError(f"{len(segmentation)} segmentations for {len(clips)} clips")
    for index, (motion, style) in enumerate(clips):
        segments = segmentation[index] if segmentation is not None else None
        found, features = clip_instances(motion, style, template, cycle, states, segments)
        instances.extend(found)
        statics.append(features)
    if cycle != "none" and any(i.unit != ONE_SHOT_UNIT for i in instances):
        instances = [i for i in instances if i.unit != ONE_SHOT_UNIT]  # clips without steps
    if not instances:
        raise ValueError("no clip is long enough to train a model")
    return instances, statics

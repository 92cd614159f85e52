"""A clip's world positions in its own body frame (first-frame hips: X to the body's left, Y
up, Z forward), so that performers facing different ways compare."""

from __future__ import annotations

from dataclasses import dataclass

from mse.motion.base.bodyparts import BodyMap, body_map
from mse.motion.base.bvh import Motion
from mse.motion.base.contacts import contact_joints
from mse.motion.base.kinematics import FloatArray
from mse.motion.base.lma import UP_AXIS, arm_length, body_frame

__all__ = ["Body", "body_of"]


@dataclass(frozen=True, slots=True)
class Body:
    """World positions in the body frame, with the joints the measures use."""

    positions: FloatArray  # (F, J, 3)
    frame_time: float
    body: BodyMap
    feet: tuple[int, ...]  # foot joints and their children (toes)
    chest: int
    scale: float  # arm length (file units)


def _hip_origin(positions: FloatArray, body: BodyMap) -> FloatArray:
    """The first-frame midpoint of the hips, at height 0."""
    origin: FloatArray = 0.5 * (positions[0, body.left_hip] + positions[0, body.right_hip])
    origin[UP_AXIS] = 0.0
    return origin


def body_of(motion: Motion, path: str = "<motion>") -> Body:
    """The clip's positions in its body frame and the joints the measures need."""
    skeleton = motion.skeleton
    body = body_map(skeleton, path)
    positions = motion.positions()
    feet = contact_joints(skeleton)
    local = body_frame(positions, body, _hip_origin(positions, body))
    return Body(local, motion.frame_time, body, feet, body.torso, arm_length(positions, body))

"""Key poses of the starter library's actions, on the starter skeleton.

Each action is a peak pose (local joint rotations in degrees, ``(x, y, z)`` in the order of
the file's ZXY channels but given here as x, y, z) plus an optional root displacement (cm)
and a base duration. The clip goes rest -> peak -> hold -> rest; :mod:`mse.motion.base.starter`
shapes the timing and the amplitude with the style's Effort.

Axes of the starter skeleton (Y up, facing +Z, the agent's left is +X, arms hang along -Y):
rotation about X bends forward (positive: the spine/head bow; negative: an arm swings forward
and up, a shin folds back), about Y turns (positive: to the agent's left), about Z rolls
sideways (positive: the left arm lifts outward, a left clavicle rises). Y is applied first
(ZXY), so a twist of the *upper* arm is what swings a bent forearm across the body. Poses named ``*_L``
only are mirrored onto ``*_R`` when ``mirror`` is set (X kept, Y and Z negated).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

Rotation = tuple[float, float, float]


@dataclass(frozen=True, slots=True)
class ActionPose:
    """The peak of an action: rotations per joint, root shift (cm), base duration (s)."""

    rotations: Mapping[str, Rotation]
    root_shift: tuple[float, float, float] = (0.0, 0.0, 0.0)
    duration: float = 2.0
    mirror: bool = False
    # joints whose motion repeats (head shakes, turns): number of swings during the hold
    swings: Mapping[str, int] = field(default_factory=dict)
    # the pose touches the body (hand on mouth, arms crossed): the style's amplitude and the
    # performer's jitter would make the hand miss, so they do not scale the limbs
    contact: bool = False

    def full_rotations(self) -> dict[str, Rotation]:
        rotations = dict(self.rotations)
        if self.mirror:
            for name, (x, y, z) in self.rotations.items():
                if name.endswith("_L"):
                    rotations.setdefault(name[:-2] + "_R", (x, -y, -z))
        return rotations


ACTIONS: Mapping[str, ActionPose] = {
    # a bow folds at the hips more than in the back, the legs leaning back a little so that
    # the hips go back over the heels (normal style: head 15 cm down; Bandai dataset 1 bows:
    # 5-35 cm, median 18.5)
    "bow": ActionPose(
        {
            "Hips": (26.0, 0.0, 0.0),
            "UpperLeg_L": (-33.0, 0.0, 0.0),
            "Foot_L": (7.0, 0.0, 0.0),
            "Spine": (8.0, 0.0, 0.0),
            "Chest": (8.0, 0.0, 0.0),
            "Neck": (6.0, 0.0, 0.0),
            "Head": (6.0, 0.0, 0.0),
            "UpperArm_L": (-12.0, 0.0, -4.0),
            "LowerArm_L": (-10.0, 0.0, 0.0),
        },
        duration=2.2,
        mirror=True,
    ),
    "head_down": ActionPose({"Neck": (22.0, 0.0, 0.0), "Head": (18.0, 0.0, 0.0)}, duration=1.6),
    # the wrist in front of the mouth (solved on the skeleton: 2 cm from its target)
    "hand_on_mouth": ActionPose(
        {
            "UpperArm_R": (-91.0, 13.0, -32.0),
            "LowerArm_R": (-122.0, 0.0, -1.0),
            "Hand_R": (0.0, 0.0, -15.0),
            "Neck": (8.0, 0.0, 0.0),
            "Head": (6.0, 0.0, 0.0),
        },
        duration=2.0,
        contact=True,
    ),
    "arms_raised": ActionPose(
        {
            "UpperArm_L": (0.0, 0.0, 155.0),
            "LowerArm_L": (0.0, 0.0, 10.0),
            "Shoulder_L": (0.0, 0.0, 10.0),
            "Chest": (-6.0, 0.0, 0.0),
            "Head": (-12.0, 0.0, 0.0),
        },
        duration=2.0,
        mirror=True,
    ),
    "hands_on_hips": ActionPose(
        {
            "UpperArm_L": (5.0, 0.0, 45.0),
            "LowerArm_L": (-15.0, 0.0, -95.0),
            "Chest": (-5.0, 0.0, 0.0),
        },
        duration=2.0,
        mirror=True,
        contact=True,
    ),
    "shrug": ActionPose(
        {
            "Shoulder_L": (0.0, 0.0, 14.0),
            "UpperArm_L": (0.0, 0.0, 12.0),
            "LowerArm_L": (-75.0, 0.0, 20.0),
            "Head": (0.0, 0.0, 8.0),
        },
        duration=1.6,
        mirror=True,
    ),
    "arms_crossed": ActionPose(
        {
            "UpperArm_L": (-30.0, -75.0, -12.0),
            "LowerArm_L": (-100.0, 0.0, 0.0),
            "Chest": (-3.0, 0.0, 0.0),
        },
        duration=2.2,
        mirror=True,
        contact=True,
    ),
    "fist_raise": ActionPose(
        {
            "UpperArm_R": (-150.0, 0.0, -10.0),
            "LowerArm_R": (-35.0, 0.0, 0.0),
            "Hand_R": (-20.0, 0.0, 0.0),
            "Chest": (-6.0, 8.0, 0.0),
            "Head": (-8.0, 0.0, 0.0),
        },
        duration=1.8,
    ),
    # the wrist at the cheek of the head turned towards it (solved like hand_on_mouth)
    "hand_on_face": ActionPose(
        {
            "UpperArm_R": (-94.0, 7.0, -16.0),
            "LowerArm_R": (-128.0, 0.0, -2.0),
            "Hand_R": (10.0, 0.0, -20.0),
            "Neck": (12.0, 0.0, -6.0),
            "Head": (8.0, 0.0, -8.0),
        },
        duration=2.2,
        contact=True,
    ),
    "step_back": ActionPose(
        {
            "UpperLeg_R": (22.0, 0.0, 0.0),
            "LowerLeg_R": (18.0, 0.0, 0.0),
            "Foot_R": (-10.0, 0.0, 0.0),
            "Chest": (-6.0, 0.0, 0.0),
            "Spine": (-4.0, 0.0, 0.0),
        },
        root_shift=(0.0, -1.5, -22.0),
        duration=1.8,
    ),
    "lean_forward": ActionPose(
        {"Spine": (10.0, 0.0, 0.0), "Chest": (10.0, 0.0, 0.0), "Neck": (-4.0, 0.0, 0.0)},
        root_shift=(0.0, 0.0, 3.0),
        duration=1.8,
    ),
    "lean_back": ActionPose(
        {"Spine": (-8.0, 0.0, 0.0), "Chest": (-8.0, 0.0, 0.0), "Neck": (5.0, 0.0, 0.0)},
        root_shift=(0.0, 0.0, -3.0),
        duration=1.8,
    ),
    "head_turn": ActionPose(
        {"Neck": (0.0, 30.0, 0.0), "Head": (0.0, 18.0, 0.0), "Chest": (0.0, 6.0, 0.0)},
        duration=1.6,
    ),
    "head_shake": ActionPose(
        {"Neck": (0.0, 18.0, 0.0), "Head": (0.0, 12.0, 0.0)},
        duration=1.6,
        swings={"Neck": 3, "Head": 3},
    ),
    "nod": ActionPose(
        {"Neck": (12.0, 0.0, 0.0), "Head": (10.0, 0.0, 0.0)},
        duration=1.4,
        swings={"Neck": 2, "Head": 2},
    ),
    "fist_clench": ActionPose(
        {
            "UpperArm_L": (-15.0, -20.0, 8.0),
            "LowerArm_L": (-70.0, 0.0, 0.0),
            "Hand_L": (-25.0, 0.0, 0.0),
            "Shoulder_L": (0.0, 0.0, 6.0),
            "Chest": (-3.0, 0.0, 0.0),
        },
        duration=1.6,
        mirror=True,
    ),
    "hands_clasp": ActionPose(
        {
            "UpperArm_L": (-25.0, -50.0, -10.0),
            "LowerArm_L": (-70.0, 0.0, 0.0),
            "Hand_L": (0.0, 0.0, -10.0),
            "Head": (5.0, 0.0, 0.0),
        },
        duration=2.0,
        mirror=True,
        contact=True,
    ),
    "hands_outward": ActionPose(
        {
            "UpperArm_L": (-25.0, 35.0, 30.0),
            "LowerArm_L": (-60.0, 0.0, 15.0),
            "Hand_L": (0.0, 0.0, 25.0),
            "Chest": (-4.0, 0.0, 0.0),
        },
        duration=1.8,
        mirror=True,
    ),
    "look_away": ActionPose(
        {"Neck": (6.0, -28.0, 0.0), "Head": (4.0, -18.0, 0.0), "Chest": (0.0, -8.0, 0.0)},
        duration=1.8,
    ),
}

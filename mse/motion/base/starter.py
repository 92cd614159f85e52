"""The embedded starter library: keyframed clips generated deterministically in code.

So that ``animate`` works on a fresh install without any motion data. The skeleton
(:func:`starter_skeleton`) uses Bandai's joint names, Y up, facing +Z, centimetres, the root
``Hips`` with six channels (XYZ position, ZXY rotation) and every other joint with three
rotation channels (ZXY); the rest pose is standing with the arms hanging.

Every action of :data:`mse.motion.base.starter_actions.ACTIONS` exists in every style of
:data:`STYLE_EFFORT` for :data:`PERFORMERS` seeded performers. A style is an Effort profile:

- ``speed`` scales the tempo (clip length = base duration / speed);
- ``amplitude`` scales the peak rotations and root displacement;
- ``sharpness`` shortens the attack and release (Sudden Time, high jerk) or lengthens them
  (Sustained), and above 1.5 adds an overshoot;
- ``posture`` adds a trunk/neck flexion in degrees (positive slumps, negative lifts the chest)
  and ``shoulders`` raises the clavicles (hunching).

Performers perturb tempo, amplitude, posture and bone lengths by a few percent (seeded), so
that the library has within-style variation like real data. Everything is cached per process.
"""

from __future__ import annotations

import functools
import hashlib

import numpy as np

from mse.diagnostics import Diagnostic, MseError, Span
from mse.motion.base.bvh import Motion, Skeleton
from mse.motion.base.kinematics import FloatArray
from mse.motion.base.library import Clip, MotionLibrary
from mse.motion.base.starter_actions import ACTIONS, ActionPose

FRAME_TIME = 1.0 / 30.0
PERFORMERS = 3
#: part of the starter library's fingerprint: raise it when :func:`generate_clip` changes, so
#: that models cached on disk from older clips are not reused
GENERATOR_VERSION = 3
_ROT = ("Zrotation", "Xrotation", "Yrotation")
_POS = ("Xposition", "Yposition", "Zposition")

# name, parent, offset (cm)
_JOINTS: tuple[tuple[str, str | None, tuple[float, float, float]], ...] = (
    ("Hips", None, (0.0, 95.0, 0.0)),
    ("Spine", "Hips", (0.0, 10.0, 0.0)),
    ("Chest", "Spine", (0.0, 20.0, 0.0)),
    ("Neck", "Chest", (0.0, 22.0, 0.0)),
    ("Head", "Neck", (0.0, 10.0, 0.0)),
    ("Shoulder_L", "Chest", (4.0, 18.0, 0.0)),
    ("UpperArm_L", "Shoulder_L", (14.0, 0.0, 0.0)),
    ("LowerArm_L", "UpperArm_L", (0.0, -28.0, 0.0)),
    ("Hand_L", "LowerArm_L", (0.0, -25.0, 0.0)),
    ("Shoulder_R", "Chest", (-4.0, 18.0, 0.0)),
    ("UpperArm_R", "Shoulder_R", (-14.0, 0.0, 0.0)),
    ("LowerArm_R", "UpperArm_R", (0.0, -28.0, 0.0)),
    ("Hand_R", "LowerArm_R", (0.0, -25.0, 0.0)),
    ("UpperLeg_L", "Hips", (9.0, -5.0, 0.0)),
    ("LowerLeg_L", "UpperLeg_L", (0.0, -42.0, 0.0)),
    ("Foot_L", "LowerLeg_L", (0.0, -42.0, 0.0)),
    ("Toes_L", "Foot_L", (0.0, -6.0, 12.0)),
    ("UpperLeg_R", "Hips", (-9.0, -5.0, 0.0)),
    ("LowerLeg_R", "UpperLeg_R", (0.0, -42.0, 0.0)),
    ("Foot_R", "LowerLeg_R", (0.0, -42.0, 0.0)),
    ("Toes_R", "Foot_R", (0.0, -6.0, 12.0)),
)
_END_SITES = {
    "Head": (0.0, 18.0, 0.0),
    "Hand_L": (0.0, -18.0, 0.0),
    "Hand_R": (0.0, -18.0, 0.0),
    "Toes_L": (0.0, 0.0, 6.0),
    "Toes_R": (0.0, 0.0, 6.0),
}

#: style -> (speed, amplitude, sharpness, posture degrees, shoulders degrees)
STYLE_EFFORT: dict[str, tuple[float, float, float, float, float]] = {
    "normal": (1.0, 1.0, 1.0, 0.0, 0.0),
    "happy": (1.25, 1.15, 1.3, -3.0, 0.0),
    "sad": (0.6, 0.7, 0.6, 12.0, 0.0),
    "angry": (1.5, 1.25, 2.2, -4.0, 3.0),
    "proud": (0.9, 1.0, 1.0, -10.0, -3.0),
    "not-confident": (0.8, 0.6, 0.8, 8.0, 8.0),
    "tired": (0.55, 0.6, 0.5, 10.0, -2.0),
    "active": (1.6, 1.3, 1.8, -2.0, 0.0),
}


_TRUNK = frozenset({"Hips", "Spine", "Chest", "Neck", "Head"})
_LEGS = frozenset(f"{part}_{side}" for part in ("UpperLeg", "LowerLeg", "Foot", "Toes") for side in "LR")


def starter_actions() -> list[str]:
    return sorted(ACTIONS)


@functools.cache
def starter_skeleton(scale: float = 1.0) -> Skeleton:
    names = tuple(j[0] for j in _JOINTS)
    parents = tuple(-1 if j[1] is None else names.index(j[1]) for j in _JOINTS)
    offsets = np.array([j[2] for j in _JOINTS], dtype=np.float64)
    offsets[1:] *= scale
    channels = tuple((_POS + _ROT) if p < 0 else _ROT for p in parents)
    ends: list[tuple[float, float, float] | None] = []
    for name in names:
        end = _END_SITES.get(name)
        ends.append(None if end is None else (end[0] * scale, end[1] * scale, end[2] * scale))
    return Skeleton(names, parents, offsets, channels, tuple(ends))


def unknown_action_error(action: str, where: Span | None = None) -> MseError:
    known = ", ".join(starter_actions())
    return MseError(
        [
            Diagnostic(
                "E213",
                f"unknown motion action {action!r}; the starter library knows: {known}",
                where or Span("<motion>"),
            )
        ]
    )


def _envelope(phase: FloatArray, sharpness: float) -> FloatArray:
    """0 -> 1 -> 0 over the clip: attack, hold, release; sharper means shorter ramps."""
    ramp = float(np.clip(0.32 / sharpness, 0.08, 0.45))
    attack_end, release_start = 0.05 + ramp, 0.95 - ramp

    def smooth(u: FloatArray) -> FloatArray:
        u = np.clip(u, 0.0, 1.0)
        return u * u * (3.0 - 2.0 * u)

    up = smooth((phase - 0.05) / (attack_end - 0.05))
    down = smooth((phase - release_start) / (0.95 - release_start))
    envelope = up * (1.0 - down)
    if sharpness > 1.5:  # sudden movements overshoot their peak and settle
        bump = np.exp(-(((phase - attack_end) / (0.5 * ramp)) ** 2))
        envelope = envelope * (1.0 + 0.12 * (sharpness - 1.0) * bump)
    return envelope


def generate_clip(action: str, style: str, performer: int = 0) -> Motion:
    """One starter clip (deterministic for the same arguments)."""
    pose = ACTIONS.get(action)
    if pose is None:
        raise unknown_action_error(action)
    if style not in STYLE_EFFORT:
        raise MseError(
            [
                Diagnostic(
                    "E213",
                    f"unknown style {style!r}; known: {', '.join(sorted(STYLE_EFFORT))}",
                    Span("<motion>"),
                )
            ]
        )
    return _generate(action, style, performer)


@functools.cache
def _generate(action: str, style: str, performer: int) -> Motion:
    pose: ActionPose = ACTIONS[action]
    speed, amplitude, sharpness, posture, shoulders = STYLE_EFFORT[style]
    seed = sum(ord(c) for c in f"{action}/{style}") * 7919 + performer
    rng = np.random.default_rng(seed)
    performer_rng = np.random.default_rng(1000 + performer)
    build = 1.0 + performer_rng.uniform(-0.05, 0.05)
    speed *= 1.0 + performer_rng.uniform(-0.08, 0.08) + rng.uniform(-0.04, 0.04)
    amplitude *= 1.0 + performer_rng.uniform(-0.08, 0.08) + rng.uniform(-0.04, 0.04)
    posture += performer_rng.uniform(-2.0, 2.0)
    skeleton = starter_skeleton(round(build, 4))
    frames = max(8, round(pose.duration / speed / FRAME_TIME))
    phase = (np.arange(frames) + 0.5) / frames
    envelope = _envelope(phase, sharpness)
    if pose.contact:  # no overshoot through the body
        envelope = np.minimum(envelope, 1.0)
    seconds = np.arange(frames) * FRAME_TIME
    rotations = np.zeros((frames, skeleton.joint_count, 3))  # x, y, z degrees
    for name, (x, y, z) in pose.full_rotations().items():
        joint = skeleton.index(name)
        jitter = rng.uniform(-3.0, 3.0, 3) * (np.abs([x, y, z]) > 0)
        scale = amplitude
        if pose.contact and skeleton.names[joint] not in _TRUNK:
            jitter, scale = 0.0 * jitter, 1.0  # the hand must reach its target
        if skeleton.names[joint] in _LEGS:
            jitter = 0.0 * jitter  # both feet stay on the floor: the legs move alike
        peak = (np.array([x, y, z]) + jitter) * scale
        swings = pose.swings.get(name, 0)
        shape = envelope
        if swings:  # oscillate during the hold, faster for faster styles
            shape = envelope * np.sin(2.0 * np.pi * swings * phase)
        rotations[:, joint] += shape[:, None] * peak[None, :]
    # posture: a constant trunk/neck flexion and clavicle raise, plus slow breathing
    for name, share in (("Spine", 0.35), ("Chest", 0.35), ("Neck", 0.3)):
        rotations[:, skeleton.index(name), 0] += posture * share
    for name, sign in (("Shoulder_L", 1.0), ("Shoulder_R", -1.0)):
        rotations[:, skeleton.index(name), 2] += sign * shoulders
    breathing = 0.8 * np.sin(2.0 * np.pi * 0.25 * seconds + performer)
    rotations[:, skeleton.index("Chest"), 0] += breathing
    root = np.tile(skeleton.offsets[0], (frames, 1))
    root += envelope[:, None] * np.array(pose.root_shift)[None, :] * amplitude
    values = np.empty((frames, skeleton.channel_count))
    for joint in range(skeleton.joint_count):
        columns = skeleton.rotation_columns(joint)  # Z, X, Y in the file
        values[:, columns[0]] = rotations[:, joint, 2]
        values[:, columns[1]] = rotations[:, joint, 0]
        values[:, columns[2]] = rotations[:, joint, 1]
    values[:, list(skeleton.position_columns(0))] = root
    return Motion(skeleton, FRAME_TIME, values)


def rest_motion(frames: int, skeleton: Skeleton | None = None) -> Motion:
    """``frames`` frames of the rest pose (root at its offset, no rotation)."""
    skeleton = skeleton or starter_skeleton()
    values = np.zeros((frames, skeleton.channel_count))
    for joint in range(skeleton.joint_count):
        columns = skeleton.position_columns(joint)
        if columns:
            values[:, list(columns)] = skeleton.offsets[joint]
    return Motion(skeleton, FRAME_TIME, values)


@functools.cache
def starter_library() -> MotionLibrary:
    """Every action x style x performer, generated lazily on first use of a clip."""
    clips = []
    preloaded: dict[str, Motion] = _LazyClips()
    for action in starter_actions():
        for style in STYLE_EFFORT:
            for performer in range(PERFORMERS):
                clip_id = f"starter_{action}_{style}_{performer + 1}"
                clips.append(Clip(clip_id, action, style, f"p{performer + 1}", f"starter:{clip_id}"))
    recipe = repr((GENERATOR_VERSION, sorted(ACTIONS.items()), sorted(STYLE_EFFORT.items()), _JOINTS, _END_SITES))
    fingerprint = hashlib.sha256(recipe.encode()).hexdigest()[:16]
    return MotionLibrary("starter", tuple(clips), {}, preloaded, fingerprint)


class _LazyClips(dict[str, Motion]):
    """A mapping that generates a starter clip the first time its id is looked up."""

    def __contains__(self, key: object) -> bool:
        return isinstance(key, str) and key.startswith("starter_")

    def __missing__(self, key: str) -> Motion:
        action, style, performer = key.removeprefix("starter_").rsplit("_", 2)
        motion = generate_clip(action, style, int(performer) - 1)
        self[key] = motion
        return motion

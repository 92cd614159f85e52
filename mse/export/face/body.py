"""The half-body view: the face rig re-framed to the hips, with a torso and two arms.

``rig.json``'s ``half_body`` section gives the frame, the shape that replaces the short
bust of the face view, and the arms: each hand hangs at the point ``hand.rest`` and moves
towards ``hand.<place>`` by the weight of the channel ``hand_<side>@<place>`` (gesture
lexemes set them, :mod:`mse.export.face.lexicon`).  Places on the head (``mouth``,
``cheek``, ``head``) turn with the head, so a hand stays at the mouth while the head bows.
The elbow follows from the shoulder and the hand by two-bone inverse kinematics, bent
towards a pole direction (out, down and back).

When the timeline has motion (a BVH per leaf, or the composed timeline file), the arms
come from it instead: :class:`ArmMotion` reads the shoulder, elbow and wrist of both sides
and maps them, scaled to the rig's arm length, onto the rig's shoulders.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cache
from typing import TYPE_CHECKING, Any

import numpy as np

from mse.export.face.rig import REST_PLACE, SIDES, FloatArray, Rig, compile_shape, default_rig, hand_channel
from mse.extras import require

if TYPE_CHECKING:
    from mse.export.figures import FigureClip

#: The views a renderer offers: the face and bust, or the half body with arms and hands.
VIEWS: tuple[str, ...] = ("half-body", "face")


@dataclass(frozen=True)
class ArmStyle:
    upper: float  # shoulder to elbow, model units
    fore: float  # elbow to wrist
    upper_width: float
    fore_width: float
    hand: float  # hand radius
    pole: tuple[float, float, float]  # the elbow bends towards this (the left arm's; x mirrored)
    sleeve: str
    edge: str
    skin: str
    skin_edge: str


@dataclass(frozen=True)
class HalfBody:
    """The compiled half-body view: the re-framed rig, the arm style and the point indices."""

    rig: Rig
    arm: ArmStyle
    shoulder: tuple[int, int]  # point index of the shoulder joint, L and R
    rest: tuple[int, int]
    places: tuple[tuple[int, int], ...]  # per rig place, the point index for L and R
    channels: tuple[tuple[int, int], ...]  # per rig place, the weight channel for L and R


def compile_half_body(rig: Rig) -> HalfBody:
    """The half-body view of ``rig`` (its ``half_body`` source section)."""
    source: Mapping[str, Any] = rig.half_body_source or {}
    if not source:
        raise ValueError("this rig has no half_body section")
    index = {name: i for i, name in enumerate(rig.names)}
    channel_index = rig.channel_index
    replace = source.get("replace", {})
    shapes = []
    for shape in rig.shapes:
        spec = replace.get(shape.id)
        shapes.append(shape if spec is None else compile_shape(spec, index, channel_index))
    view = source["view"]
    framed = dataclasses.replace(
        rig,
        shapes=tuple(shapes),
        view_box=(float(view["box"][0]), float(view["box"][1])),
        origin=(float(view["origin"][0]), float(view["origin"][1])),
    )
    arm = source["arm"]
    style = ArmStyle(
        float(arm["upper"]),
        float(arm["fore"]),
        float(arm["upper_width"]),
        float(arm["fore_width"]),
        float(arm["hand"]),
        (float(arm["pole"][0]), float(arm["pole"][1]), float(arm["pole"][2])),
        str(arm["sleeve"]),
        str(arm["edge"]),
        str(arm["skin"]),
        str(arm["skin_edge"]),
    )

    def pair(stem: str) -> tuple[int, int]:
        return index[f"{stem}.L"], index[f"{stem}.R"]

    return HalfBody(
        framed,
        style,
        pair("arm.shoulder"),
        pair(f"hand.{REST_PLACE}"),
        tuple(pair(f"hand.{place}") for place in rig.places),
        tuple((channel_index[hand_channel("L", p)], channel_index[hand_channel("R", p)]) for p in rig.places),
    )


@cache
def default_half_body() -> HalfBody:
    return compile_half_body(default_rig())


def elbow(shoulder: FloatArray, hand: FloatArray, upper: float, fore: float, pole: FloatArray) -> FloatArray:
    """Two-bone inverse kinematics: the elbow for a shoulder and a hand position (the hand
    is pulled in to the arm's reach), bent towards ``pole``."""
    reach = hand - shoulder
    distance = float(np.linalg.norm(reach))
    if distance < 1e-9:
        return shoulder + pole / max(float(np.linalg.norm(pole)), 1e-9) * upper
    axis = reach / distance
    distance = min(max(distance, abs(upper - fore) + 1e-6), upper + fore - 1e-6)
    along = (upper * upper - fore * fore + distance * distance) / (2.0 * distance)
    height = math.sqrt(max(upper * upper - along * along, 0.0))
    bend = pole - axis * float(pole @ axis)
    norm = float(np.linalg.norm(bend))
    if norm < 1e-9:  # the pole lies along the arm: any perpendicular
        bend = np.cross(axis, np.array([0.0, 0.0, 1.0]))
        norm = float(np.linalg.norm(bend)) or 1.0
    result: FloatArray = shoulder + axis * along + bend / norm * height
    return result


Arm = tuple[FloatArray, FloatArray, FloatArray]  # shoulder, elbow, wrist


def arm_joints(body: HalfBody, model: FloatArray, values: FloatArray) -> list[Arm]:
    """``(shoulder, elbow, wrist)`` in posed model coordinates for the L and R arms, from the
    hand-place channels."""
    arm = body.arm
    arms = []
    for side in range(len(SIDES)):
        shoulder = model[body.shoulder[side]]
        rest = model[body.rest[side]]
        weights = np.array([max(0.0, float(values[channels[side]])) for channels in body.channels])
        total = float(weights.sum())
        if total > 1.0:
            weights = weights / total
        hand = rest.copy()
        for weight, points in zip(weights, body.places, strict=True):
            if weight > 0.0:
                hand += weight * (model[points[side]] - rest)
        pole = np.array(arm.pole) * np.array([1.0 if side == 0 else -1.0, 1.0, 1.0])
        joint = elbow(shoulder, hand, arm.upper, arm.fore, pole)
        direction = hand - joint
        length = float(np.linalg.norm(direction))
        wrist = joint + direction / length * arm.fore if length > 1e-9 else hand
        arms.append((shoulder, joint, wrist))
    return arms


@dataclass(frozen=True)
class ArmMotion:
    """Arms from motion clips: per clip, per frame, the elbow and wrist relative to the
    shoulder of both sides, in rig model units (x to the agent's left, y down, z forward)."""

    clips: tuple[tuple[float, float, float, FloatArray], ...]  # (start, stop, fps, [frame, side, joint(2), xyz])

    def at(self, time: float) -> FloatArray | None:
        """``[side, (elbow, wrist), xyz]`` offsets from the shoulder at ``time``, or None."""
        found: FloatArray | None = None
        for start, stop, fps, frames in self.clips:
            if start <= time < stop:
                found = frames[min(len(frames) - 1, max(0, math.floor((time - start) * fps)))]
        return found


def arm_motion(clips: Sequence[FigureClip], body: HalfBody) -> ArmMotion | None:
    """The arms of motion clips whose skeletons name both arms; None when none does."""
    from mse.motion.base.bodyparts import split_name

    def wrist_of(split: list[tuple[str, str]], side: str) -> int | None:
        for core in ("wrist", "hand"):
            for joint, (joint_side, joint_core) in enumerate(split):
                if joint_side == side and joint_core == core:
                    return joint
        return None

    found = []
    for clip in clips:
        split = [split_name(name) for name in clip.joints]
        chains = []
        for side in ("left", "right"):
            wrist = wrist_of(split, side)
            if wrist is None:
                break
            elbow_joint = clip.parents[wrist]
            shoulder = clip.parents[elbow_joint] if elbow_joint >= 0 else -1
            if shoulder < 0:
                break
            chains.append((shoulder, elbow_joint, wrist))
        if len(chains) != 2:
            continue
        positions = clip.positions
        if positions.size == 0:
            continue
        first = positions[0]
        length = np.mean(
            [
                np.linalg.norm(first[e] - first[s]) + np.linalg.norm(first[w] - first[e])
                for s, e, w in chains
            ]
        )
        if length <= 1e-9:
            continue
        scale = (body.arm.upper + body.arm.fore) / float(length)
        # BVH body frame: X to the body's left, Y up, Z forward; the rig: x left, y down, z forward.
        flip = np.array([1.0, -1.0, 1.0]) * scale
        frames = np.stack(
            [
                np.stack([(positions[:, e] - positions[:, s]) * flip, (positions[:, w] - positions[:, s]) * flip], 1)
                for s, e, w in chains
            ],
            axis=1,
        )
        found.append((clip.start, clip.stop, clip.fps, frames))
    return ArmMotion(tuple(found)) if found else None


def draw_arms(
    canvas: Any,
    body: HalfBody,
    arms: Sequence[tuple[FloatArray, FloatArray, FloatArray]],
    to_screen: Any,
    scale: float,
) -> None:
    """Sleeves, forearms and hands on an aggdraw canvas; ``to_screen`` projects model points
    ``[n, 3]`` to pixels ``[n, 2]``; widths shrink with distance like the face does."""
    with require("video"):
        import aggdraw

    arm = body.arm
    focal = body.rig.focal
    # Far arm first: the one whose hand is nearer the viewer is drawn over the other.
    order = sorted(range(len(arms)), key=lambda side: float(arms[side][2][2]))
    for side in order:
        shoulder, joint, wrist = arms[side]
        points = to_screen(np.stack([shoulder, joint, wrist]))
        depth = [focal / (focal - float(p[2])) for p in (shoulder, joint, wrist)]
        (sx, sy), (ex, ey), (wx, wy) = (tuple(float(v) for v in p) for p in points)
        upper_width = arm.upper_width * scale * (depth[0] + depth[1]) / 2.0
        fore_width = arm.fore_width * scale * (depth[1] + depth[2]) / 2.0
        edge = 1.5 * scale
        outline = aggdraw.Pen(arm.edge, upper_width + 2 * edge)
        canvas.line((sx, sy, ex, ey), outline)
        canvas.line((ex, ey, wx, wy), aggdraw.Pen(arm.edge, fore_width + 2 * edge))
        for (ax, ay), width in (((sx, sy), upper_width), ((ex, ey), (upper_width + fore_width) / 2.0)):
            r = width / 2.0 + edge
            canvas.ellipse((ax - r, ay - r, ax + r, ay + r), aggdraw.Brush(arm.edge))
        sleeve = aggdraw.Brush(arm.sleeve)
        canvas.line((sx, sy, ex, ey), aggdraw.Pen(arm.sleeve, upper_width))
        canvas.line((ex, ey, wx, wy), aggdraw.Pen(arm.sleeve, fore_width))
        for (ax, ay), width in (((sx, sy), upper_width), ((ex, ey), (upper_width + fore_width) / 2.0)):
            r = width / 2.0
            canvas.ellipse((ax - r, ay - r, ax + r, ay + r), sleeve)
        # The hand: a palm beyond the wrist along the forearm, with a thumb.
        dx, dy = wx - ex, wy - ey
        norm = math.hypot(dx, dy) or 1.0
        ux, uy = dx / norm, dy / norm
        radius = arm.hand * scale * depth[2]
        cx, cy = wx + ux * radius * 0.7, wy + uy * radius * 0.7
        skin = aggdraw.Brush(arm.skin)
        pen = aggdraw.Pen(arm.skin_edge, 1.2 * scale)
        thumb_side = 1.0 if side == 0 else -1.0
        tx, ty = cx - uy * radius * 0.8 * thumb_side, cy + ux * radius * 0.8 * thumb_side
        tr = radius * 0.42
        canvas.ellipse((tx - tr, ty - tr, tx + tr, ty + tr), pen, skin)
        canvas.ellipse((cx - radius, cy - radius * 1.0, cx + radius, cy + radius * 1.0), pen, skin)
        cuff = aggdraw.Pen(arm.edge, max(1.0, 2.0 * scale))
        half = fore_width / 2.0
        canvas.line((wx - uy * half, wy + ux * half, wx + uy * half, wy - ux * half), cuff)

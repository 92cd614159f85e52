"""Finding the body parts of a skeleton by joint-name patterns.

Joint names differ across datasets; the LMA features need six points and the right arm:

| part | Bandai and starter | CMU (cgspeed) | MoDa |
|---|---|---|---|
| head | Head | Head | Head |
| left_hand, right_hand | Hand_L, Hand_R | lhand, rhand | LeftHand, RightHand |
| left_foot, right_foot | Foot_L, Foot_R | LeftAnkle, RightAnkle | LeftFoot, RightFoot |
| torso | Chest | Chest | Spine |
| right wrist (arm length) | Hand_R | RightWrist | RightHand |

A name is split into a side (prefix ``Left``/``l``, suffix ``_L``/``.L``/``Left``, same for
right) and a core (the rest, lower case). Each part takes the first core in its preference
list (hand: hand, wrist; foot: foot, ankle; torso: chest, spine2, spine1, spine, upperchest,
lowerback). The arm length is shoulder->elbow->wrist: the wrist-like joint (wrist, then hand)
and its parent and grandparent, measured on the posed clip.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from mse.diagnostics import Diagnostic, MseError, Span
from mse.motion.base.bvh import Skeleton

PARTS: tuple[str, ...] = ("head", "left_hand", "right_hand", "left_foot", "right_foot", "torso")

_LIMB_WORDS = (
    "hand|wrist|foot|ankle|shoulder|elbow|hip|knee|toe|toes|fingers|thumb|forearm|arm|upleg|leg"
    "|collar|clavicle|upperarm|lowerarm|upperleg|lowerleg|toebase"
)
_SHORT_PREFIX = re.compile(rf"^([lr])({_LIMB_WORDS})$")
_LONG_PREFIX = re.compile(r"^(left|right)[_.\s]?(.+)$")
_SUFFIX = re.compile(r"^(.+?)[_.\s]?(l|r|left|right)$")

_PREFERENCES: dict[str, tuple[str, ...]] = {
    "head": ("head",),
    "hand": ("hand", "wrist"),
    "foot": ("foot", "ankle"),
    "torso": ("chest", "spine2", "spine1", "spine", "upperchest", "lowerback"),
    "wrist": ("wrist", "hand"),
}


def split_name(name: str) -> tuple[str, str]:
    """``(side, core)`` with side ``"left"``, ``"right"`` or ``""``; core in lower case."""
    lower = name.lower()
    match = _SHORT_PREFIX.match(lower)
    if match:
        return ("left" if match.group(1) == "l" else "right"), match.group(2)
    match = _LONG_PREFIX.match(lower)
    if match:
        return match.group(1), match.group(2)
    if re.search(r"[_.](l|r)$", lower) or re.search(r"(left|right)$", lower):
        match = _SUFFIX.match(lower)
        if match:
            side = match.group(2)
            return ("left" if side.startswith("l") else "right"), match.group(1)
    return "", lower


@dataclass(frozen=True, slots=True)
class BodyMap:
    """Joint indices of the LMA body parts and of the right arm chain."""

    head: int
    left_hand: int
    right_hand: int
    left_foot: int
    right_foot: int
    torso: int
    right_shoulder: int
    right_elbow: int
    right_wrist: int
    left_hip: int
    right_hip: int

    def part_indices(self) -> tuple[int, ...]:
        """Joint index of each of :data:`PARTS`, in that order."""
        return (
            self.head,
            self.left_hand,
            self.right_hand,
            self.left_foot,
            self.right_foot,
            self.torso,
        )


def body_map(skeleton: Skeleton, path: str = "<skeleton>") -> BodyMap:
    """Locate the body parts; raises MseError (E100) naming the part that is missing."""
    split = [split_name(n) for n in skeleton.names]

    def find(kind: str, side: str) -> int:
        for core in _PREFERENCES[kind]:
            for joint, (joint_side, joint_core) in enumerate(split):
                if joint_side == side and joint_core == core:
                    return joint
        label = f"{side} {kind}".strip()
        raise MseError(
            [
                Diagnostic(
                    "E100",
                    f"cannot find the {label} joint among {', '.join(skeleton.names)}",
                    Span(path),
                )
            ]
        )

    def ancestor(joint: int, steps: int) -> int:
        for _ in range(steps):
            parent = skeleton.parents[joint]
            joint = parent if parent >= 0 else joint
        return joint

    right_wrist = find("wrist", "right")
    left_foot, right_foot = find("foot", "left"), find("foot", "right")
    return BodyMap(
        head=find("head", ""),
        left_hand=find("hand", "left"),
        right_hand=find("hand", "right"),
        left_foot=left_foot,
        right_foot=right_foot,
        torso=find("torso", ""),
        right_shoulder=ancestor(right_wrist, 2),
        right_elbow=ancestor(right_wrist, 1),
        right_wrist=right_wrist,
        left_hip=ancestor(left_foot, 2),
        right_hip=ancestor(right_foot, 2),
    )


def _subtree(skeleton: Skeleton, joint: int) -> list[int]:
    out = [joint]
    for child in skeleton.children(joint):
        out.extend(_subtree(skeleton, child))
    return out


def limb_groups(skeleton: Skeleton) -> dict[str, list[int]]:
    """Every joint in one of four parts: ``left_arm`` / ``right_arm`` (from the joint below
    the torso on the way to the hand, usually the clavicle, down to the fingers), ``legs``
    (the subtrees of both hips) and ``trunk`` (the rest: root, spine, neck, head).

    A skeleton without recognisable hands or feet puts everything in ``trunk``."""
    groups: dict[str, list[int]] = {"trunk": [], "left_arm": [], "right_arm": [], "legs": []}
    try:
        body = body_map(skeleton)
    except MseError:
        groups["trunk"] = list(range(skeleton.joint_count))
        return groups

    def arm_root(hand: int) -> int:
        chain = [hand]
        while skeleton.parents[chain[-1]] >= 0 and chain[-1] != body.torso:
            chain.append(skeleton.parents[chain[-1]])
        # the joint just below the torso (or the shoulder's parent chain's top)
        return chain[-2] if len(chain) >= 2 and chain[-1] == body.torso else chain[min(2, len(chain) - 1)]

    taken: set[int] = set()
    for name, start in (("left_arm", arm_root(body.left_hand)), ("right_arm", arm_root(body.right_hand))):
        groups[name] = [j for j in _subtree(skeleton, start) if j not in taken]
        taken.update(groups[name])
    for hip in (body.left_hip, body.right_hip):
        groups["legs"] += [j for j in _subtree(skeleton, hip) if j not in taken]
        taken.update(groups["legs"])
    groups["trunk"] = [j for j in range(skeleton.joint_count) if j not in taken]
    return groups

"""Greta's ``HeadGestures.xml`` as rotations for the face player.

The file is read by :mod:`mse.export.realizer_libraries` (the one reader of Greta's realizer
libraries); here each ``<head id lexeme>`` becomes an :class:`Action`.  Its key points hold
``SagittalTilt`` (Forward/Backward), ``VerticalTorsion`` (Leftward/Rightward) and
``LateralRoll`` amounts ``min``..``max`` in Greta's symbolic units (a fraction of the
anatomical maximum, which Greta keeps in ``HeadIntervals.xml``; we take
:data:`MAX_DEGREES`).  The player uses the middle of the range.  An untyped key point is a
held pose; stroke key points are movements: one goes there and back (``NOD``), two in
opposite directions swing between them (``SHAKE``).  Lookups go by ``id`` and, for the first
head of a lexeme, by ``lexeme`` (``NOD``, ``embarrassment_signal_1``), in lower case, as
Greta's.  Held orientations (``<headDirectionShift>``) are a different BML behaviour and are
not head lexemes.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from mse.export.face.actions import Action
from mse.export.realizer_libraries import MovementLibrary, Rotation
from mse.export.realizer_libraries import load_head_gestures as read_head_gestures

#: Degrees of Greta's symbolic 1.0 per axis (our assumption; HeadIntervals.xml is not public).
MAX_DEGREES = {"SagittalTilt": 40.0, "VerticalTorsion": 70.0, "LateralRoll": 35.0}
#: Rig channel and the sign of each direction (yaw > 0 left, pitch > 0 down, roll > 0 left).
_AXES = {
    ("SagittalTilt", "forward"): ("head_pitch", 1.0),
    ("SagittalTilt", "backward"): ("head_pitch", -1.0),
    ("VerticalTorsion", "leftward"): ("head_yaw", 1.0),
    ("VerticalTorsion", "rightward"): ("head_yaw", -1.0),
    ("LateralRoll", "leftward"): ("head_roll", 1.0),
    ("LateralRoll", "rightward"): ("head_roll", -1.0),
}
SWING_PERIOD = 0.6


def _pose(rotations: Sequence[Rotation]) -> dict[str, float]:
    """Channel -> degrees of one key point."""
    pose: dict[str, float] = {}
    for rotation in rotations:
        axis = _AXES.get((rotation.axis, rotation.direction.lower()))
        if axis is None:
            continue
        channel, sign = axis
        middle = (rotation.minimum + rotation.maximum) / 2.0
        pose[channel] = pose.get(channel, 0.0) + sign * MAX_DEGREES[rotation.axis] * middle
    return pose


def _action(poses: list[dict[str, float]], strokes: bool, source: str) -> Action:
    """A held pose, or a movement: typed key points (``strokeStart``/``strokeEnd``) go
    there and back (a bump), two opposite key points swing between them (a sine)."""
    if len(poses) >= 2:
        first, second = poses[0], poses[1]
        shared = [c for c in first if c in second and first[c] * second[c] < 0]
        if shared:
            channel = shared[0]
            amplitude = (abs(first[channel]) + abs(second[channel])) / 2.0
            sign = 1.0 if first[channel] > 0 else -1.0
            return Action(((channel, sign * amplitude),), source, oscillate=(SWING_PERIOD, "sine"))
        if set(first) == set(second) and all(first[c] * second[c] > 0 for c in first):
            return Action(tuple(first.items()), source, oscillate=(SWING_PERIOD, "bump"))
    first = poses[0] if poses else {}
    if strokes and first:
        return Action(tuple(first.items()), source, oscillate=(SWING_PERIOD, "bump"))
    return Action(tuple(first.items()), source)


def head_actions(library: MovementLibrary, source: str) -> dict[str, Action]:
    """``id``/``lexeme`` (lower case) -> action, for the ``<head>`` entries of a library."""
    table: dict[str, Action] = {}
    by_lexeme: dict[str, Action] = {}
    for movement in library.movements:
        if movement.kind != "head":
            continue
        poses = [pose for pose in (_pose(point.rotations) for point in movement.keypoints) if pose]
        strokes = any(point.type.startswith("stroke") for point in movement.keypoints)
        action = _action(poses, strokes, source)
        if movement.id:
            table[movement.id.lower()] = action
        if movement.lexeme:
            by_lexeme.setdefault(movement.lexeme.lower(), action)
    for lexeme, action in by_lexeme.items():
        table.setdefault(lexeme, action)
    return table


def load_head_gestures(path: Path) -> dict[str, Action]:
    """Read ``HeadGestures.xml`` (unreadable E100, malformed XML E101, too large E104)."""
    return head_actions(read_head_gestures(path), path.name)

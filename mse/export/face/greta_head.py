"""Greta's ``HeadGestures.xml``: head lexemes as rotations for the face player.

Each ``<head id lexeme>`` holds key points with ``SagittalTilt`` (Forward/Backward),
``VerticalTorsion`` (Leftward/Rightward) and ``LateralRoll`` amounts ``min``..``max`` in
Greta's symbolic units (a fraction of the anatomical maximum, which Greta keeps in
``HeadIntervals.xml``; we take :data:`MAX_DEGREES`).  The player uses the middle of the
range.  An untyped key point is a held pose; stroke key points are movements: one
goes there and back (``NOD``), two in opposite directions swing between them
(``SHAKE``).  Lookups go by ``id`` and, for the first head of a
lexeme, by ``lexeme`` (``NOD``, ``embarrassment_signal_1``), in lower case.
"""

from __future__ import annotations

from pathlib import Path

from mse.diagnostics import Diagnostic, MseError, Span
from mse.export.face.actions import Action

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


def _key_point(node: object) -> dict[str, float]:
    """Channel -> degrees of one ``<KeyPoint>``."""
    pose: dict[str, float] = {}
    for child in node:  # type: ignore[attr-defined]
        if not isinstance(child.tag, str):
            continue
        axis = _AXES.get((child.tag, (child.get("direction") or "").strip().lower()))
        if axis is None:
            continue
        try:
            low = float(child.get("min", "0"))
            high = float(child.get("max", child.get("min", "0")))
        except ValueError:
            continue
        channel, sign = axis
        pose[channel] = pose.get(channel, 0.0) + sign * MAX_DEGREES[child.tag] * (low + high) / 2.0
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
            return Action(((channel, sign * amplitude),), source, oscillate=(0.6, "sine"))
        if set(first) == set(second) and all(first[c] * second[c] > 0 for c in first):
            return Action(tuple(first.items()), source, oscillate=(0.6, "bump"))
    first = poses[0] if poses else {}
    if strokes and first:
        return Action(tuple(first.items()), source, oscillate=(0.6, "bump"))
    return Action(tuple(first.items()), source)


def load_head_gestures(path: Path) -> dict[str, Action]:
    """``id``/``lexeme`` (lower case) -> action; unreadable E100, malformed XML E101."""
    from lxml import etree

    try:
        data = path.read_bytes()
    except OSError as error:
        raise MseError(
            [Diagnostic("E100", f"cannot read head library: {error.strerror or error}", Span(str(path)))]
        ) from None
    parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False, huge_tree=False)
    try:
        root = etree.fromstring(data, parser)
    except etree.XMLSyntaxError as error:
        line, col = error.position
        raise MseError(
            [Diagnostic("E101", f"head library is not well-formed XML: {error.msg}", Span(str(path), line, col))]
        ) from None
    table: dict[str, Action] = {}
    by_lexeme: dict[str, Action] = {}
    for head in root.iter("head"):
        points = list(head.iter("KeyPoint"))
        poses = [pose for pose in (_key_point(point) for point in points) if pose]
        strokes = any((point.get("type") or "").startswith("stroke") for point in points)
        action = _action(poses, strokes, path.name)
        ident = (head.get("id") or "").strip().lower()
        lexeme = (head.get("lexeme") or "").strip().lower()
        if ident:
            table[ident] = action
        if lexeme and lexeme not in by_lexeme:
            by_lexeme[lexeme] = action
    for lexeme, action in by_lexeme.items():
        table.setdefault(lexeme, action)
    return table

"""What a lexeme does to the face player: an :class:`Action` over the rig's channels.

FACS action units become the rig's sided channels (``AU12:L``, ``AU12:R``); head (51-58)
and eye (61-64) units become rotations and gaze; a few units are drawn as a neighbour
(AU45 blink as AU43 eye closure).  Kept apart from the readers of tables and libraries,
which all produce actions.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

#: Action units the rig draws (with both sides); others are reported, not drawn.
RIG_UNITS: frozenset[int] = frozenset(
    {1, 2, 4, 5, 6, 7, 9, 10, 12, 13, 14, 15, 16, 17, 18, 20, 22, 23, 24, 25, 26, 27, 43}
)
#: Units drawn as another unit of the rig, scaled: blink, droop, slit, squint.
UNIT_ALIASES: Mapping[int, tuple[int, float]] = {
    45: (43, 1.0),
    41: (43, 0.3),
    42: (43, 0.6),
    44: (7, 1.0),
    46: (43, 1.0),
}
#: Head (51-58) and eye (61-64) units as rotations and gaze: channel, amount at intensity 1.
UNIT_MOTIONS: Mapping[int, tuple[str, float]] = {
    51: ("head_yaw", 30.0),
    52: ("head_yaw", -30.0),
    53: ("head_pitch", -20.0),
    54: ("head_pitch", 20.0),
    55: ("head_roll", 20.0),
    56: ("head_roll", -20.0),
    57: ("head_forward", 30.0),
    58: ("head_forward", -30.0),
    61: ("gaze_x", 1.0),
    62: ("gaze_x", -1.0),
    63: ("gaze_y", -1.0),
    64: ("gaze_y", 1.0),
}


@dataclass(frozen=True)
class Action:
    """What one lexeme does: channel targets (rig channel names) and timing."""

    targets: tuple[tuple[str, float], ...]
    source: str
    attack: float | None = None
    release: float | None = None
    repeat: tuple[float, float] | None = None  # (every, length) seconds
    oscillate: tuple[float, str] | None = None  # (period, "sine" | "bump")
    unsupported: tuple[int, ...] = ()  # action units the rig cannot show
    #: The FACS units the targets come from (number, intensity 0-1, side), when the source
    #: names units: BML without a face library falls back to core lexemes through them.
    units: tuple[tuple[int, float, str], ...] = ()


def unit_targets(number: int, side: str, intensity: float) -> tuple[list[tuple[str, float]], bool]:
    """Rig channels of one FACS unit; the flag says whether the rig can show it."""
    if number in UNIT_MOTIONS:
        channel, amount = UNIT_MOTIONS[number]
        return [(channel, amount * intensity)], True
    scale = 1.0
    if number in UNIT_ALIASES:
        number, scale = UNIT_ALIASES[number]
    if number not in RIG_UNITS:
        return [], False
    sides = ("L", "R") if side == "BOTH" else (side[0],)
    return [(f"AU{number}:{s}", intensity * scale) for s in sides], True

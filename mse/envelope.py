"""The envelope of an occurrence: how strongly, and with which attack, sustain and release, the
agent shows it (the one description every reader uses: timelines, the face player, BML).

An occurrence [start, stop] rises from 0 to its *intensity* during ``attack``, holds during
``sustain`` and falls back to 0 during ``release``: ``attack + sustain + release = stop - start``.
Phase lengths are per modality (:data:`PHASES`), never more than :data:`MAX_PHASE_SHARE` of the
occurrence each; a lexicon entry of the face player may give its own attack and release.

An occurrence *cut* by an emotion change that was not announced at ``cut`` (docs/semantics.md, "Episodes")
starts its release at the cut, the face not knowing earlier, and releases within
:data:`CUT_RELEASE` seconds (never past its planned stop): its stop becomes
``min(planned stop, cut + release)``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

#: Default (attack, release) in seconds per modality.
PHASES: Mapping[str, tuple[float, float]] = {
    "face": (0.3, 0.3),
    "gaze": (0.12, 0.12),
    "head": (0.35, 0.35),
    "torso": (0.6, 0.6),
    "posture": (0.6, 0.6),
}
DEFAULT_PHASES = (0.3, 0.3)
#: Attack and release each take at most this share of the occurrence.
MAX_PHASE_SHARE = 0.4
#: The longest release of an occurrence cut by an unannounced change (seconds).
CUT_RELEASE = 0.2


@dataclass(frozen=True, slots=True)
class Envelope:
    """Intensity in [0, 1] and the three phases in seconds (they add up to the length)."""

    intensity: float
    attack: float
    sustain: float
    release: float

    def to_json(self) -> dict[str, float]:
        return {
            "intensity": round(self.intensity, 4),
            "attack": round(self.attack, 3),
            "sustain": round(self.sustain, 3),
            "release": round(self.release, 3),
        }


def phases(
    modality: str, length: float, attack: float | None = None, release: float | None = None
) -> tuple[float, float]:
    """(attack, release) of an occurrence of ``length`` seconds in ``modality``; ``attack`` and
    ``release`` override the modality's defaults (a face-lexicon entry's own timing)."""
    default_attack, default_release = PHASES.get(modality, DEFAULT_PHASES)
    limit = MAX_PHASE_SHARE * max(length, 0.0)
    rise = default_attack if attack is None else attack
    fall = default_release if release is None else release
    return min(rise, limit), min(fall, limit)


def envelope(modality: str, start: float, stop: float, intensity: float = 1.0) -> Envelope:
    """The envelope of an uncut occurrence."""
    length = stop - start
    attack, release = phases(modality, length)
    return Envelope(intensity, attack, max(0.0, length - attack - release), release)


def cut_envelope(
    modality: str, start: float, planned_stop: float, cut: float, intensity: float = 1.0, *, final: bool = False
) -> tuple[float, Envelope]:
    """(new stop, envelope) of an occurrence planned over [start, planned_stop] and cut at ``cut``:
    the attack as planned (shortened if the cut comes first), the release from the cut.  At the
    dialogue's end (``final``) no time follows: the occurrence stops at the cut, releasing over
    the last :data:`CUT_RELEASE` seconds before it (at most 40 % of what was played)."""
    attack, _ = phases(modality, planned_stop - start)
    if final:
        played = cut - start
        rise, fall = min(attack, MAX_PHASE_SHARE * played), min(CUT_RELEASE, MAX_PHASE_SHARE * played)
        return cut, Envelope(intensity, rise, max(0.0, played - rise - fall), fall)
    stop = min(planned_stop, cut + CUT_RELEASE)
    attack = min(attack, cut - start)
    release = stop - cut
    return stop, Envelope(intensity, attack, max(0.0, cut - start - attack), release)

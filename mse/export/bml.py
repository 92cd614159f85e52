"""BML 1.0 (http://www.bml-initiative.org/bml/bml-1.0): one ``<bml>`` block per timeline.

Every occurrence becomes one behaviour with absolute ``start``/``end`` in seconds:
realizers do not enforce ``<constraint>`` (that is why the times are solved here), so
constraints are only written as optional metadata.  docs/export.md lists the mappings.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from mse.export.lexemes import (
    ActionUnit,
    FaceLibrary,
    Lexeme,
    format_seconds,
    load_face_library,
    modality_of,
    sanitize_id,
    split_lexeme,
    unique_ids,
    upper_token,
)
from mse.export.options import COMPOSITIONS, ExportOptions
from mse.export.xmltext import Comment, Element, document, element
from mse.timeline import Timeline, TimelineSignal

BML_NAMESPACE = "http://www.bml-initiative.org/bml/bml-1.0"
#: Namespace of the ``ext:`` prefix (BML 1.0 core extensions); only with ``bml_extensions``.
EXT_NAMESPACE = "http://www.bml-initiative.org/bml/coreextensions-1.0"

#: Greta / common face names -> BML 1.0 core faceLexeme values.
FACE_LEXEMES: Mapping[str, str] = {
    "smile": "RAISE_MOUTH_CORNERS",
    "joy": "RAISE_MOUTH_CORNERS",
    "happy": "RAISE_MOUTH_CORNERS",
    "slight_smile": "RAISE_MOUTH_CORNERS",
    "frown": "LOWER_BROWS",
    "eyebrows_frown": "LOWER_BROWS",
    "anger": "LOWER_BROWS",
    "raise_eyebrows": "RAISE_BROWS",
    "eyebrows_raise": "RAISE_BROWS",
    "surprise": "RAISE_BROWS",
    "sad": "LOWER_MOUTH_CORNERS",
    "sadness": "LOWER_MOUTH_CORNERS",
    "worry": "OBLIQUE_BROWS",
    "fear": "WIDEN_EYES",
    "widen_eyes": "WIDEN_EYES",
    "eyes_closed": "CLOSE_EYES",
    "close_eyes": "CLOSE_EYES",
    "open_mouth": "OPEN_MOUTH",
    "open_lips": "OPEN_LIPS",
}

#: FACS action unit -> BML 1.0 core faceLexeme (used when a face library resolves a name).
AU_LEXEMES: Mapping[int, str] = {
    1: "OBLIQUE_BROWS",
    2: "RAISE_BROWS",
    4: "LOWER_BROWS",
    5: "WIDEN_EYES",
    12: "RAISE_MOUTH_CORNERS",
    13: "RAISE_MOUTH_CORNERS",
    15: "LOWER_MOUTH_CORNERS",
    25: "OPEN_LIPS",
    26: "OPEN_MOUTH",
    27: "OPEN_MOUTH",
    43: "CLOSE_EYES",
    45: "CLOSE_EYES",
}

#: Gaze action units of Greta's face library (class ``gaze``) -> direction words.
_GAZE_AUS: Mapping[int, str] = {61: "LEFT", 62: "RIGHT", 63: "UP", 64: "DOWN"}
_GAZE_ANGLE_DEGREES = 20.0


@dataclass(frozen=True, slots=True)
class Behaviour:
    """One occurrence ready to be written: its unique id, lexeme and export modality."""

    id: str
    signal: TimelineSignal
    lexeme: Lexeme
    modality: str

    @property
    def start(self) -> str:
        return format_seconds(self.signal.start)

    @property
    def end(self) -> str:
        return format_seconds(self.signal.stop)


def plan_behaviours(timeline: Timeline) -> list[Behaviour]:
    """The timeline's occurrences with BML-safe unique ids, in time order."""
    ids = unique_ids(s.id for s in timeline.signals)
    return [
        Behaviour(bid, s, lexeme, modality_of(s.modality, lexeme))
        for bid, s in zip(ids, timeline.signals, strict=True)
        for lexeme in (split_lexeme(s.lexeme),)
    ]


def block_id(timeline: Timeline) -> str:
    """The ``<bml id>``: an xs:ID (no leading digit) that is never the reserved ``bml``."""
    return "bml_" + sanitize_id(timeline.expression or "timeline", prefix="")


def composition(options: ExportOptions) -> str:
    value = options.composition.strip().upper()
    return value if value in COMPOSITIONS else "MERGE"


def gaze_direction(lexeme: Lexeme, units: Sequence[ActionUnit] | None) -> str | None:
    """``look_down_left`` -> ``DOWNLEFT`` (BML offsetDirection), from AUs 61-64 or the name."""
    words: set[str] = set()
    if units:
        words = {_GAZE_AUS[u.number] for u in units if u.number in _GAZE_AUS}
    if not words:
        tokens = set(re.split(r"[^a-z]+", lexeme.name.lower()))
        words = {w.upper() for w in ("up", "down", "left", "right") if w in tokens}
    vertical = "UP" if "UP" in words else "DOWN" if "DOWN" in words else ""
    horizontal = "LEFT" if "LEFT" in words else "RIGHT" if "RIGHT" in words else ""
    return (vertical + horizontal) or None


def face_lexeme(lexeme: Lexeme, units: Sequence[ActionUnit] | None) -> tuple[str, float | None]:
    """The BML core faceLexeme for a face signal and its amount (None: realizer default)."""
    known = FACE_LEXEMES.get(lexeme.name.lower())
    if known is not None:
        return known, None
    if units:
        mapped = [u for u in units if u.number in AU_LEXEMES]
        if mapped:
            strongest = max(mapped, key=lambda u: u.intensity)
            if strongest.number == 1 and any(u.number == 2 for u in mapped):
                return "RAISE_BROWS", strongest.intensity
            return AU_LEXEMES[strongest.number], strongest.intensity
    # Not a core lexeme: keep the name (openSetItem accepts any token), upper-cased.
    return upper_token(lexeme.name), None


def timing(b: Behaviour) -> dict[str, str | float | int | None]:
    return {"id": b.id, "start": b.start, "end": b.end}


def _face(b: Behaviour, library: FaceLibrary | None, extensions: bool) -> list[Element]:
    units = library.resolve(b.lexeme) if library is not None else None
    if extensions and units:
        # One ext:faceFacs per action unit; ids stay unique with an _auN suffix.
        return [
            element(
                "ext:faceFacs",
                {
                    "id": f"{b.id}_au{u.number}",
                    "start": b.start,
                    "end": b.end,
                    "au": u.number,
                    "side": u.side,
                    "amount": format_seconds(u.intensity),
                },
            )
            for u in units
        ]
    name, amount = face_lexeme(b.lexeme, units)
    attrs = timing(b)
    attrs["lexeme"] = name
    attrs["amount"] = None if amount is None else format_seconds(amount)
    return [element("faceLexeme", attrs)]


def _gaze(b: Behaviour, library: FaceLibrary | None, options: ExportOptions) -> Element:
    units = library.resolve(b.lexeme) if library is not None else None
    direction = gaze_direction(b.lexeme, units)
    attrs = timing(b)
    attrs["target"] = options.gaze_target
    attrs["influence"] = "EYES"
    if direction is not None:
        attrs["offsetAngle"] = format_seconds(_GAZE_ANGLE_DEGREES)
        attrs["offsetDirection"] = direction
    return element("gaze", attrs)


def _behaviour_elements(b: Behaviour, library: FaceLibrary | None, options: ExportOptions) -> list[Element | Comment]:
    name = upper_token(b.lexeme.name)
    if b.modality == "face":
        return list(_face(b, library, options.bml_extensions))
    if b.modality == "gaze":
        return [_gaze(b, library, options)]
    if b.modality == "head":
        head = b.lexeme.name.lower().removeprefix("head_") or b.lexeme.name
        return [element("head", {**timing(b), "lexeme": upper_token(head)})]
    if b.modality == "gesture":
        return [element("gesture", {**timing(b), "lexeme": name})]
    if b.modality in ("torso", "posture"):
        # The schema wants a stance or a pose inside <posture>; its <pose> has no 'part'.
        return [
            element(
                "posture",
                timing(b),
                element("stance", {"type": "STANDING"}),
                element("pose", {"lexeme": name}),
            )
        ]
    if b.modality == "speech" and b.lexeme.name:
        return [element("speech", timing(b), element("text", {}, b.lexeme.name))]
    return [Comment(f"{b.id}: modality {b.modality or '?'!r} has no BML 1.0 behaviour")]


def sync_constraints(behaviours: Sequence[Behaviour]) -> list[Element]:
    """``<constraint><synchronize>`` for sync points that share a time (metadata only)."""
    by_time: dict[str, list[str]] = {}
    for b in behaviours:
        by_time.setdefault(b.start, []).append(f"{b.id}:start")
        by_time.setdefault(b.end, []).append(f"{b.id}:end")
    blocks = []
    for refs in by_time.values():
        if len(refs) > 1:
            syncs = [element("sync", {"ref": ref}) for ref in refs]
            blocks.append(element("constraint", {}, element("synchronize", {}, *syncs)))
    return blocks


def optional_face_library(options: ExportOptions) -> FaceLibrary | None:
    return load_face_library(options.face_library) if options.face_library is not None else None


def render_bml(timeline: Timeline, options: ExportOptions) -> str:
    library = optional_face_library(options)
    behaviours = plan_behaviours(timeline)
    children: list[Element | Comment | str] = []
    for b in behaviours:
        children.extend(_behaviour_elements(b, library, options))
    if options.bml_constraints:
        children.extend(sync_constraints(behaviours))
    if not any(isinstance(c, Element) for c in children):
        # The schema needs at least one behaviour: an empty timeline is a zero-length wait.
        children.append(element("wait", {"id": "empty", "start": "0", "duration": "0"}))
    attrs: dict[str, str | float | int | None] = {
        "xmlns": BML_NAMESPACE,
        "xmlns:ext": EXT_NAMESPACE if options.bml_extensions else None,
        "id": block_id(timeline),
        "characterId": options.character_id,
        "composition": composition(options),
    }
    return document(element("bml", attrs, *children), leading=(Comment(provenance(timeline)),))


def provenance(timeline: Timeline) -> str:
    """``embarrassment — 10 s — solver greedy — seed 7``: what made this timeline."""
    seed = "none" if timeline.seed is None else str(timeline.seed)
    return (
        f"{timeline.expression or 'timeline'} — {format_seconds(timeline.duration)} s — "
        f"solver {timeline.solver} — seed {seed}"
    )

"""BML 1.0 (http://www.bml-initiative.org/bml/bml-1.0): one ``<bml>`` block per timeline.

Every occurrence becomes one behaviour with absolute ``start``/``end`` in seconds:
realizers do not enforce ``<constraint>`` (that is why the times are solved here), so
constraints are only written as optional metadata.  The ``generic`` and ``asap`` profiles
write BML 1.0 core (docs/export.md lists the mappings); ``--realizer greta`` writes the
elements Greta reads (:mod:`mse.export.greta_bml`) inside a BML 1.0 block.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from mse.export.behaviours import Behaviour, block_id, composition, plan_behaviours, provenance, timing
from mse.export.greta_bml import greta_elements
from mse.export.lexemes import format_seconds, upper_token
from mse.export.options import ExportOptions
from mse.export.realizer_libraries import ActionUnit, FaceLibrary, load_face_library
from mse.export.realizers import lexeme_table, realize_gaze, realizer_for
from mse.export.xmltext import Comment, Element, document, element
from mse.timeline import Timeline

__all__ = ["Behaviour", "block_id", "composition", "plan_behaviours", "provenance", "render_bml", "timing"]

BML_NAMESPACE = "http://www.bml-initiative.org/bml/bml-1.0"
#: Namespace of the ``ext:`` prefix (BML 1.0 core extensions); only with ``bml_extensions``.
EXT_NAMESPACE = "http://www.bml-initiative.org/bml/coreextensions-1.0"

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

_GAZE_ANGLE_DEGREES = 20.0
#: ``<pose part>`` for a torso or posture signal: BML 1.0 requires a part (AsapRealizer rejects a
#: pose without one); the shared XSD, which forbids it, is wrong there (docs/realizers.md).
POSE_PART = "WHOLEBODY"
#: ``amount`` when nothing gives one: BML 1.0 realizers play a missing amount at 0.5.
FULL_AMOUNT = "1"


def face_lexeme(realizer: str, name: str, units: Sequence[ActionUnit] | None) -> tuple[str, float | None]:
    """The BML core faceLexeme for a face signal and its amount (None: not given by the library)."""
    entry = lexeme_table(realizer).lookup("face", name)
    if entry is not None:
        return entry.name, None
    if units:
        mapped = [u for u in units if u.number in AU_LEXEMES]
        if mapped:
            strongest = max(mapped, key=lambda u: u.intensity)
            if strongest.number == 1 and any(u.number == 2 for u in mapped):
                return "RAISE_BROWS", strongest.intensity
            return AU_LEXEMES[strongest.number], strongest.intensity
    # Not a core lexeme: keep the name (openSetItem accepts any token), upper-cased.
    return upper_token(name), None


def head_lexeme(realizer: str, name: str) -> str:
    """``nod`` -> ``NOD`` (table); otherwise the name without ``head_``, upper case."""
    entry = lexeme_table(realizer).lookup("head", name)
    if entry is not None:
        return entry.name
    return upper_token(name.lower().removeprefix("head_") or name)


def _face(b: Behaviour, realizer: str, library: FaceLibrary | None, extensions: bool) -> list[Element]:
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
    name, amount = face_lexeme(realizer, b.lexeme.name, units)
    attrs = timing(b)
    attrs["lexeme"] = name
    attrs["amount"] = FULL_AMOUNT if amount is None else format_seconds(amount)
    return [element("faceLexeme", attrs)]


def _gaze(b: Behaviour, realizer: str, library: FaceLibrary | None, options: ExportOptions) -> Element:
    units = library.resolve(b.lexeme) if library is not None else None
    direction = realize_gaze(realizer, b.lexeme, units).name
    attrs = timing(b)
    attrs["target"] = options.gaze_target
    attrs["influence"] = "EYES"
    if direction:
        attrs["offsetAngle"] = format_seconds(_GAZE_ANGLE_DEGREES)
        attrs["offsetDirection"] = direction
    return element("gaze", attrs)


def _behaviour_elements(
    b: Behaviour, realizer: str, library: FaceLibrary | None, options: ExportOptions
) -> list[Element | Comment]:
    name = upper_token(b.lexeme.name)
    if b.modality == "face":
        return list(_face(b, realizer, library, options.bml_extensions))
    if b.modality == "gaze":
        return [_gaze(b, realizer, library, options)]
    if b.modality == "head":
        return [element("head", {**timing(b), "lexeme": head_lexeme(realizer, b.lexeme.name), "amount": FULL_AMOUNT})]
    if b.modality == "gesture":
        return [element("gesture", {**timing(b), "lexeme": name})]
    if b.modality in ("torso", "posture"):
        return [
            element(
                "posture",
                timing(b),
                element("stance", {"type": "STANDING"}),
                element("pose", {"part": POSE_PART, "lexeme": name}),
            )
        ]
    if b.modality == "speech" and b.lexeme.name:
        return [element("speech", timing(b), element("text", {}, b.lexeme.name))]
    return [Comment(f"{b.id}: modality {b.modality or '?'!r} has no BML 1.0 behaviour")]


def sync_constraints(written: Sequence[Element | Comment | str]) -> list[Element]:
    """``<constraint><synchronize>`` for sync points that share a time (metadata only).

    Built from the behaviours actually written (ext:faceFacs ids, no comment-only
    occurrences): a reference to a behaviour the block lacks makes AsapRealizer drop it."""
    by_time: dict[str, list[str]] = {}
    for node in written:
        if not isinstance(node, Element) or "id" not in node.attributes or "start" not in node.attributes:
            continue
        bid = node.attributes["id"]
        by_time.setdefault(str(node.attributes["start"]), []).append(f"{bid}:start")
        by_time.setdefault(str(node.attributes["end"]), []).append(f"{bid}:end")
    blocks = []
    for refs in by_time.values():
        if len(refs) > 1:
            syncs = [element("sync", {"ref": ref}) for ref in refs]
            blocks.append(element("constraint", {}, element("synchronize", {}, *syncs)))
    return blocks


def optional_face_library(options: ExportOptions) -> FaceLibrary | None:
    return load_face_library(options.face_library) if options.face_library is not None else None


def render_bml(timeline: Timeline, options: ExportOptions) -> str:
    realizer = realizer_for("bml", options.realizer)
    behaviours = plan_behaviours(timeline)
    children: list[Element | Comment | str] = []
    if realizer == "greta":
        children.extend(greta_elements(behaviours, options))
    else:
        library = optional_face_library(options)
        for b in behaviours:
            children.extend(_behaviour_elements(b, realizer, library, options))
    if options.bml_constraints:
        children.extend(sync_constraints(children))
    if not any(isinstance(c, Element) for c in children):
        # BML 1.0 needs at least one behaviour: an empty timeline is a zero-length wait.
        children.append(element("wait", {"id": "empty", "start": "0", "duration": "0"}))
    attrs: dict[str, str | float | int | None] = {
        "xmlns": BML_NAMESPACE,
        "xmlns:ext": EXT_NAMESPACE if options.bml_extensions else None,
        "id": block_id(timeline),
        "characterId": options.character_id,
        "composition": composition(options),
    }
    return document(element("bml", attrs, *children), leading=(Comment(provenance(timeline)),))

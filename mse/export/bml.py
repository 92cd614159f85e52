"""BML 1.0 (http://www.bml-initiative.org/bml/bml-1.0): one ``<bml>`` block per timeline.

Every occurrence becomes one behaviour with absolute ``start``/``end`` in seconds:
realizers do not enforce ``<constraint>`` (that is why the times are solved here), so
constraints are only written as optional metadata.  The ``generic`` and ``asap`` profiles
write BML 1.0 core (docs/export.md lists the mappings); ``--realizer greta`` writes the
elements Greta reads (:mod:`mse.export.greta_bml`) inside a BML 1.0 block.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from mse.diagnostics import Diagnostic, Span
from mse.export.behaviours import Behaviour, amount, block_id, composition, plan_behaviours, provenance, timing
from mse.export.greta_bml import greta_elements
from mse.export.lexemes import format_seconds, split_lexeme, upper_token
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

#: The lexemes BML 1.0 defines for ``<faceLexeme>`` and ``<head>`` (the standard's core
#: sets); other names are open-set items only a realizer with them in its own lexicon plays.
CORE_FACE_LEXEMES = frozenset({
    "OBLIQUE_BROWS", "RAISE_BROWS", "RAISE_LEFT_BROW", "RAISE_RIGHT_BROW", "LOWER_BROWS", "LOWER_LEFT_BROW",
    "LOWER_RIGHT_BROW", "LOWER_MOUTH_CORNERS", "LOWER_LEFT_MOUTH_CORNER", "LOWER_RIGHT_MOUTH_CORNER",
    "RAISE_MOUTH_CORNERS", "RAISE_RIGHT_MOUTH_CORNER", "RAISE_LEFT_MOUTH_CORNER", "OPEN_MOUTH", "OPEN_LIPS",
    "WIDEN_EYES", "CLOSE_EYES",
})
CORE_HEAD_LEXEMES = frozenset({"NOD", "SHAKE"})

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


def face_player_units(lexeme_text: str) -> tuple[ActionUnit, ...] | None:
    """The action units the face player shows for a lexeme (its bundled table and rules), so
    that a face the realizer table lacks still gets a core lexeme (None: no units known)."""
    from mse.export.face.lexicon import bundled_table, rule_action

    lexeme = split_lexeme(lexeme_text)
    action = bundled_table().get(lexeme.reference.lower()) or bundled_table().get(lexeme.name.lower())
    action = action or rule_action(lexeme, "face")
    if action is None or not action.units:
        return None
    return tuple(ActionUnit(number, intensity, side) for number, intensity, side in action.units)


def _face(b: Behaviour, realizer: str, library: FaceLibrary | None, extensions: bool) -> list[Element]:
    units = library.resolve(b.lexeme) if library is not None else None
    if units is None and lexeme_table(realizer).lookup("face", b.lexeme.name) is None:
        units = face_player_units(b.lexeme.reference)
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
                    "amount": amount(b, u.intensity),
                },
            )
            for u in units
        ]
    name, strength = face_lexeme(realizer, b.lexeme.name, units)
    attrs = timing(b)
    attrs["lexeme"] = name
    attrs["amount"] = amount(b, strength) or FULL_AMOUNT
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
        return [element("head", {**timing(b), "lexeme": head_lexeme(realizer, b.lexeme.name),
                                 "amount": amount(b) or FULL_AMOUNT})]
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


def core_lexeme_notes(timeline: Timeline, options: ExportOptions, where: str) -> list[Diagnostic]:
    """W603 once per lexeme the generic or asap BML writes outside BML 1.0's core sets (read
    back from the written block: what a realizer receives)."""
    from lxml import etree

    written = render_bml(timeline, options)
    root = etree.fromstring(written.encode("utf-8"), etree.XMLParser(resolve_entities=False, no_network=True))
    seen: dict[tuple[str, str], list[str]] = {}
    for node in root.iter():
        tag = etree.QName(node).localname if isinstance(node.tag, str) else ""
        lexeme = node.get("lexeme")
        if lexeme is None or tag not in ("faceLexeme", "head", "gesture", "pose"):
            continue
        if (tag == "faceLexeme" and lexeme in CORE_FACE_LEXEMES) or (tag == "head" and lexeme in CORE_HEAD_LEXEMES):
            continue
        parent = node.getparent()
        owner = node.get("id") or (parent.get("id") if parent is not None else None)
        seen.setdefault((tag, lexeme), []).append(str(owner or "?"))
    notes = []
    for (tag, lexeme), ids in seen.items():
        core = {"faceLexeme": "core: its 17 face lexemes", "head": "core: NOD and SHAKE"}.get(
            tag, f"it leaves {tag} lexemes to each realizer"
        )
        occurrences = ", ".join(ids[:3]) + (", …" if len(ids) > 3 else "")
        notes.append(Diagnostic(
            "W603",
            f"<{tag} lexeme={lexeme!r}> ({occurrences}) is not a BML 1.0 lexeme ({core}): a realizer plays it "
            "only if its own lexicon has it (docs/export.md)",
            Span(where),
        ))
    return notes


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
    if timeline.utterances:
        from mse.export.speech_bml import with_speech

        children = with_speech(timeline.utterances, behaviours, children, greta=realizer == "greta")
    if options.bml_constraints:
        children.extend(sync_constraints(children))
    if not any(isinstance(c, Element) for c in children):
        # BML 1.0 needs at least one behaviour: an empty timeline is a zero-length wait.
        children.append(element("wait", {"id": "empty", "start": "0", "duration": "0"}))
    attrs: dict[str, str | float | int | None] = {
        "xmlns": BML_NAMESPACE,
        "xmlns:ext": EXT_NAMESPACE if options.bml_extensions else None,
        "id": block_id(timeline, options),
        "characterId": options.character_id,
        "composition": composition(options),
    }
    return document(element("bml", attrs, *children), leading=(Comment(provenance(timeline)),))

"""The BML Greta's realizer reads (``greta.core.signals.BMLTranslator``), and the Greta profile.

Greta matches element names case-insensitively and ignores namespaces, so the same elements
serve ``--format greta-bml`` (Greta's mindmakers namespace, lower-case composition
``blend``/``append``/``replace``) and ``--format bml --realizer greta`` (a BML 1.0 block):

- faces as ``<faceLexeme lexeme="small_joy" amount="1"/>`` (Greta looks up ``faceexp=<lexeme>``
  and keeps the behaviour id, which ``<face><lexeme/></face>`` would not);
- heads, gestures and torsos with a ``<description type="gretabml"><reference>`` naming the
  library entry (HeadGestures id, gestuary ``category=id``, TorsoGestures id);
- ``<torso>`` as a behaviour of its own, written only when Greta has the torso: a torso Greta
  cannot find makes its realizer throw and drop the whole block, so it is left out (an XML
  comment and a W601 note name it);
- gaze as a direction (``offsetDirection``, 20 degrees), speech as plain text.

mse names map to Greta names through ``realizer_tables/greta.toml``; the names of imported
Greta sets are Greta's own and pass unchanged.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from mse.diagnostics import Diagnostic, Span
from mse.export.behaviours import Behaviour, amount, block_id, composition, plan_behaviours, provenance, timing
from mse.export.lexemes import Lexeme
from mse.export.options import ExportOptions
from mse.export.realizer_libraries import FaceLibrary, GretaLibraries, load_face_library
from mse.export.realizers import greta_libraries, realize_gaze, realize_greta, realizer_for
from mse.export.xmltext import Comment, Element, document, element
from mse.timeline import Timeline

GRETA_BML_NAMESPACE = "http://www.mindmakers.org/projects/BML"
EXT_NAMESPACE = "http://www.bml-initiative.org/bml/coreextensions-1.0"
GRETA_COMPOSITION: Mapping[str, str] = {"MERGE": "blend", "APPEND": "append", "REPLACE": "replace"}
GAZE_ANGLE = "20"


def _description(reference: str) -> Element:
    """Greta's parametric-signal description: the reference plus neutral expressivity."""
    parameters = [element("reference", {}, reference), element("intensity", {}, "1.00")]
    for name in ("SPC", "TMP", "FLD", "PWR", "REP", "OPN", "TEN"):
        parameters.append(element(f"{name}.value", {}, "0.00"))
    return element("description", {"priority": "1", "type": "gretabml"}, *parameters)


def _faces(b: Behaviour, libraries: GretaLibraries | None, face: FaceLibrary | None, extensions: bool) -> list[Element]:
    realized = realize_greta("face", b.lexeme, libraries)
    units = face.resolve(Lexeme("faceexp", realized.name)) if face is not None else None
    if extensions and units:
        # Greta reads ext:faceFacs as action-unit keyframes at the behaviour's times.
        return [
            element(
                "ext:faceFacs",
                {
                    **timing(b),
                    "id": f"{b.id}_au{u.number}",
                    "au": u.number,
                    "side": u.side,
                    "amount": amount(b, u.intensity),
                },
            )
            for u in units
        ]
    return [element("faceLexeme", {**timing(b), "lexeme": realized.name, "amount": amount(b) or "1"})]


def left_out(b: Behaviour, libraries: GretaLibraries | None) -> str | None:
    """Why a behaviour is not written for Greta, or None when it is: a torso Greta cannot find
    (its realizer throws on it), or a face, head, gesture or torso without a name (an empty
    ``<reference>`` makes Greta's BML reader throw)."""
    if b.modality not in ("face", "head", "gesture", "torso", "posture"):
        return None
    realized = realize_greta(b.modality, b.lexeme, libraries)
    if not realized.name.rpartition("=")[2].strip():
        return (
            f"{b.modality} signal {b.signal.id!r} ({b.signal.lexeme or 'no lexeme'}) left out: "
            "it names nothing Greta can look up"
        )
    if b.modality not in ("torso", "posture") or realized.known:
        return None
    if realized.known is None:
        where = "a torso mse knows Greta has (give --library-dir with Greta's TorsoGestures.xml to check yours)"
    else:
        hint = f"; did you mean {realized.suggestion!r}?" if realized.suggestion else ""
        where = f"in {libraries.torso.path if libraries else 'TorsoGestures.xml'}{hint}"
    return (
        f"torso signal {b.signal.id!r} ({b.signal.lexeme}) left out: {realized.name!r} is not {where}; "
        "Greta's realizer throws on a torso it cannot find and plays nothing of the block"
    )


def _greta_element(
    b: Behaviour, libraries: GretaLibraries | None, face: FaceLibrary | None, extensions: bool
) -> list[Element | Comment]:
    reason = left_out(b, libraries)
    if reason is not None:
        return [Comment(f"{b.id}: {reason}")]
    if b.modality == "face":
        return list(_faces(b, libraries, face, extensions))
    if b.modality == "gaze":
        units = face.resolve(Lexeme("gaze", b.lexeme.name)) if face is not None else None
        direction = realize_gaze("greta", b.lexeme, units).name
        attrs = {**timing(b), "target": "", "influence": "EYES"}
        if direction:
            attrs.update(offsetDirection=direction, offsetAngle=GAZE_ANGLE)
        # Greta's gaze parser ignores the description; it keeps the lexicon name visible.
        described = (_description(b.lexeme.reference),) if b.lexeme.reference else ()
        return [element("gaze", attrs, *described)]
    if b.modality == "head":
        # Greta finds a head by the reference's HeadGestures id, then by the lexeme attribute.
        name = realize_greta("head", b.lexeme, libraries).name
        return [element("head", {**timing(b), "lexeme": name}, _description(name))]
    if b.modality == "gesture":
        reference = realize_greta("gesture", b.lexeme, libraries).name
        lexeme = reference.partition("=")[2] or reference
        return [element("gesture", {**timing(b), "lexeme": lexeme}, _description(reference))]
    if b.modality in ("torso", "posture"):
        name = realize_greta("torso", b.lexeme, libraries).name
        return [element("torso", {**timing(b), "lexeme": name}, _description(f"torso={name}"))]
    if b.modality == "speech" and b.lexeme.name:
        # Plain text: Greta hands the element's text to its TTS (a BML 1.0 <text> child would
        # reach it as markup).
        return [element("speech", {**timing(b), "language": "english", "text": ""}, b.lexeme.name)]
    return [Comment(f"{b.id}: modality {b.modality or '?'!r} is not read by Greta")]


def _face_library(options: ExportOptions, libraries: GretaLibraries | None) -> FaceLibrary | None:
    if options.face_library is not None:
        return load_face_library(options.face_library)
    return libraries.face if libraries is not None else None


def greta_elements(behaviours: Sequence[Behaviour], options: ExportOptions) -> list[Element | Comment]:
    """The Greta profile's elements for ``behaviours`` (any namespace: Greta ignores it)."""
    libraries = greta_libraries(options.library_dir)
    face = _face_library(options, libraries)
    children: list[Element | Comment] = []
    for b in behaviours:
        children.extend(_greta_element(b, libraries, face, options.bml_extensions))
    return children


def greta_notes(timeline: Timeline, options: ExportOptions, where: str = "<export>") -> list[Diagnostic]:
    """W601 for every behaviour the Greta profile leaves out of the file."""
    libraries = greta_libraries(options.library_dir)
    notes = []
    for b in plan_behaviours(timeline):
        reason = left_out(b, libraries)
        if reason is not None:
            notes.append(Diagnostic("W601", reason, Span(where)))
    return notes


def render_greta_bml(timeline: Timeline, options: ExportOptions) -> str:
    realizer_for("greta-bml", options.realizer)
    behaviours = plan_behaviours(timeline)
    children: list[Element | Comment | str] = list(greta_elements(behaviours, options))
    if timeline.utterances:
        from mse.export.speech_bml import with_speech

        children = with_speech(timeline.utterances, behaviours, children, greta=True)
    attrs: dict[str, str | float | int | None] = {
        "xmlns": GRETA_BML_NAMESPACE,
        "xmlns:ext": EXT_NAMESPACE if options.bml_extensions else None,
        "id": block_id(timeline, options),
        "characterId": options.character_id,
        "composition": GRETA_COMPOSITION[composition(options)],
    }
    return document(element("bml", attrs, *children), leading=(Comment(provenance(timeline)),))

"""The BML dialect Greta's realizer reads (``greta.core.signals.BMLTranslator``).

Differences from BML 1.0: the old mindmakers namespace, lower-case composition
(``blend``/``append``/``replace``), faces as ``<face><lexeme lexeme="…"/></face>`` (Greta
prefixes ``faceexp=`` itself), ``<torso>`` as a behaviour of its own, and a
``<description type="gretabml"><reference>…</reference>`` child carrying the lexicon's
reference (``emotion=embarrassment_signal_10``) for gestures, heads and torsos.  The
lexemes of imported Greta sets are Greta's own names, so Greta plays the file unchanged.
"""

from __future__ import annotations

from collections.abc import Mapping

from mse.export.bml import (
    Behaviour,
    block_id,
    composition,
    gaze_direction,
    optional_face_library,
    plan_behaviours,
    provenance,
    timing,
)
from mse.export.lexemes import FaceLibrary, Lexeme, upper_token
from mse.export.options import ExportOptions
from mse.export.xmltext import Comment, Element, document, element
from mse.timeline import Timeline

GRETA_BML_NAMESPACE = "http://www.mindmakers.org/projects/BML"
GRETA_COMPOSITION: Mapping[str, str] = {"MERGE": "blend", "APPEND": "append", "REPLACE": "replace"}


def _description(reference: str) -> Element:
    """Greta's parametric-signal description: the reference plus neutral expressivity."""
    parameters = [element("reference", {}, reference), element("intensity", {}, "1.00")]
    for name in ("SPC", "TMP", "FLD", "PWR", "REP", "OPN", "TEN"):
        parameters.append(element(f"{name}.value", {}, "0.00"))
    return element("description", {"priority": "1", "type": "gretabml"}, *parameters)


def _reference(lexeme: Lexeme, default_class: str) -> str:
    """``emotion=x`` stays as is; a bare name gets the class Greta's parser would add."""
    if lexeme.klass or not default_class:
        return lexeme.reference
    return f"{default_class}={lexeme.name}"


def _greta_elements(b: Behaviour, library: FaceLibrary | None) -> list[Element | Comment]:
    if b.modality == "face":
        # Greta reads <lexeme lexeme="X"/> as the face-library reference faceexp=X.
        return [element("face", {**timing(b), "amount": "1"}, element("lexeme", {"lexeme": b.lexeme.name}))]
    if b.modality == "gaze":
        units = library.resolve(b.lexeme) if library is not None else None
        direction = gaze_direction(b.lexeme, units)
        attrs = timing(b)
        attrs["target"] = ""
        attrs["influence"] = "EYES"
        if direction is not None:
            attrs["offsetDirection"] = direction
            attrs["offsetAngle"] = "20.0"
        # Greta's gaze parser ignores the description; it keeps the lexicon name visible.
        return [element("gaze", attrs, _description(b.lexeme.reference))]
    if b.modality == "head":
        # Greta's own names (HeadGestures.xml ids such as embarrassment_signal_1, lexicon
        # lexemes such as DOWN) pass unchanged; mse's head=head_down becomes DOWN.
        name = b.lexeme.name
        if b.lexeme.klass.lower() == "head":
            name = upper_token(name.lower().removeprefix("head_") or name)
        return [element("head", {**timing(b), "lexeme": name}, _description(name))]
    if b.modality == "gesture":
        attrs = {**timing(b), "lexeme": b.lexeme.name}
        return [element("gesture", attrs, _description(_reference(b.lexeme, "gesture")))]
    if b.modality in ("torso", "posture"):
        attrs = {**timing(b), "lexeme": b.lexeme.name}
        return [element("torso", attrs, _description(_reference(b.lexeme, "torso")))]
    if b.modality == "speech" and b.lexeme.name:
        attrs = {**timing(b), "language": "english", "text": ""}
        return [element("speech", attrs, b.lexeme.name)]
    return [Comment(f"{b.id}: modality {b.modality or '?'!r} is not read by Greta")]


def render_greta_bml(timeline: Timeline, options: ExportOptions) -> str:
    library = optional_face_library(options)
    children: list[Element | Comment | str] = []
    for b in plan_behaviours(timeline):
        children.extend(_greta_elements(b, library))
    attrs: dict[str, str | float | int | None] = {
        "xmlns": GRETA_BML_NAMESPACE,
        "id": block_id(timeline),
        "characterId": options.character_id,
        "composition": GRETA_COMPOSITION[composition(options)],
    }
    return document(element("bml", attrs, *children), leading=(Comment(provenance(timeline)),))

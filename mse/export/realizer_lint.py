"""W308: signals whose lexeme a realizer cannot resolve in its own libraries.

``mse lint --realizer greta --library-dir DIR`` looks every signal up the way the Greta profile
writes it and Greta's SignalFiller finds it (:func:`mse.export.realizers.realize_greta`), and
reports each miss at the signal's ``file:line:col`` with the closest library name.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

from mse.diagnostics import Diagnostic, argument_error
from mse.export.lexemes import modality_of, split_lexeme
from mse.export.realizer_libraries import GretaLibraries
from mse.export.realizers import Realized, check_realizer, greta_libraries, realize_greta
from mse.ir.model import Model

#: Modalities a realizer plays from a library (speech goes to its TTS; others are W307).
_CHECKED = ("face", "head", "gaze", "gesture", "torso", "posture")
_LOOKUP = {
    "face": "faceexp={name} in the face library",
    "head": "{name} among HeadGestures ids and lexemes",
    "gesture": "{name} in the gestuary",
    "torso": "{name} among TorsoGestures ids",
    "posture": "{name} among TorsoGestures ids",
}


def realizer_libraries_for_lint(realizer: str, library_dir: Path | None) -> GretaLibraries:
    """The libraries ``realizer`` is linted against (E130 when there are none to read)."""
    check_realizer(realizer)
    if realizer != "greta":
        message = f"--realizer {realizer}: mse reads no libraries of this realizer (its parser accepts any lexeme)"
        raise argument_error(message + "; lint against --realizer greta")
    libraries = greta_libraries(library_dir)
    if libraries is None:
        message = "--realizer greta needs --library-dir: the folder of Greta's facelibrary.xml, HeadGestures.xml, "
        raise argument_error(message + "TorsoGestures.xml and gestuary")
    return libraries


def lint_realizer(model: Model, libraries: GretaLibraries) -> Iterator[Diagnostic]:
    """W308 for every signal of ``model`` Greta cannot resolve with ``libraries``."""
    for signal in model.signals:
        lexeme = split_lexeme(signal.lexeme)
        modality = modality_of(signal.modality, lexeme)
        if modality not in _CHECKED:
            continue
        realized = realize_greta(modality, lexeme, libraries)
        if realized.known:
            continue
        yield Diagnostic("W308", _message(signal.id, signal.lexeme, modality, realized), signal.span)


def _message(signal_id: str, lexeme: str, modality: str, realized: Realized) -> str:
    head = f"signal {signal_id!r}: Greta cannot resolve {modality} lexeme {lexeme!r}"
    if modality == "gaze":
        return f"{head}: Greta has no gaze lexicon and the name gives no direction, so it plays as a look at the target"
    mapped = f" (mse's greta table maps it to {realized.name!r})" if realized.source == "table" else ""
    looked = _LOOKUP[modality].format(name=realized.name)
    text = f"{head}{mapped}: no {looked}"
    if realized.suggestion:
        suggestion = f"faceexp={realized.suggestion}" if modality == "face" else realized.suggestion
        text += f"; did you mean {suggestion!r}?"
    if modality in ("torso", "posture"):
        text += "; the greta profile leaves it out of the BML (Greta's realizer would throw on it)"
    return text

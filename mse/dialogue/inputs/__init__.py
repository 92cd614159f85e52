"""Inputs the upstream already writes, read as dialogue events: FML-APML (Greta's dialogue
side, :mod:`mse.dialogue.inputs.fml`) and W3C EmotionML (:mod:`mse.dialogue.inputs.emotionml`).
docs/dialogue-inputs.md says what each maps to and what is reported."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from mse.diagnostics import Diagnostic, MseError, Span
from mse.dialogue.inputs.common import (
    EmotionNames,
    InputEvent,
    InputReading,
    known_emotion,
    load_emotion_names,
    load_xml,
    localname,
)

__all__ = [
    "EmotionNames",
    "InputEvent",
    "InputReading",
    "is_markup_input",
    "load_emotion_names",
    "read_dialogue_input",
    "read_input",
]

if TYPE_CHECKING:
    from mse.dialogue.script import Event

#: Root element -> format name.
FORMATS = {"fml-apml": "fml-apml", "emotionml": "emotionml"}


def is_markup_input(path: str | Path) -> bool:
    """Whether ``path`` looks like an XML input rather than a JSON Lines script (its first
    non-blank character is ``<``)."""
    try:
        with open(path, "rb") as stream:
            head = stream.read(512).lstrip(b"\xef\xbb\xbf \t\r\n")
    except OSError:
        return False
    return head.startswith(b"<")


def read_input(
    path: str | Path,
    *,
    names: EmotionNames | None = None,
    known: Callable[[str, Span], bool] = known_emotion,
) -> InputReading:
    """The dialogue events of an FML-APML or EmotionML file (told apart by the root element)."""
    doc = load_xml(path, what="dialogue input")
    root = localname(doc.root)
    if root == "fml-apml":
        from mse.dialogue.inputs.fml import read_fml

        return read_fml(doc, names=names, known=known)
    if root == "emotionml":
        from mse.dialogue.inputs.emotionml import read_emotionml

        return read_emotionml(doc, names=names, known=known)
    message = f"root element <{root}> is neither <fml-apml> (FML-APML) nor <emotionml> (EmotionML)"
    raise MseError([Diagnostic("E150", message, doc.span(doc.root))])


def read_dialogue_input(
    path: str | Path,
    *,
    names: EmotionNames | None = None,
    known: Callable[[str, Span], bool] = known_emotion,
) -> tuple[list[Event], list[Diagnostic]]:
    """The script events of an FML-APML or EmotionML file, checked as a script's are
    (:func:`mse.dialogue.script.parse_events`: E217 at the element's place), and the warnings
    about what mse does not use of it (print them: nothing may be dropped without a word)."""
    from mse.dialogue.script import parse_events

    reading = read_input(path, names=names, known=known)
    if not any("emotion" in e.event for e in reading.events):
        where = next((w.span for w in reading.warnings if w.code == "W528"), Span(str(path), 1, 1))
        nothing = Diagnostic("E150", "nothing to play: no emotion mse can play (see the warnings)", where)
        raise MseError([nothing, *reading.warnings])
    events = parse_events((dict(e.event), e.span) for e in reading.events)
    return events, list(reading.warnings)


def read_events(path: str | Path, *, names: EmotionNames | None = None) -> tuple[list[Event], list[Diagnostic]]:
    """What ``mse live`` reads: a JSON Lines script, or an FML-APML or EmotionML file (its first
    character is ``<``), as script events and the warnings about what was not used."""
    from mse.dialogue.script import read_script

    if str(path) != "-" and is_markup_input(path):
        return read_dialogue_input(path, names=names)
    return read_script(path), []

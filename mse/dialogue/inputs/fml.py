"""FML-APML as Greta's dialogue side writes it, read into dialogue events.

A file holds a ``<bml>`` part with the ``<speech>`` (text with ``<tm id>`` time marks, pitch
accents, boundaries) and an ``<fml>`` part with communicative functions whose ``start``/``end``
refer to the marks (``s1:tm3``, ``s1:tm8+0.5``), to another function (``e1:end``) or give
seconds (``0``, ``5.0``).  mse reads it as Greta's ``FMLTranslator`` does (checked against
Greta's own reader, tests/test_dialogue_inputs_fml.py) and keeps what a dialogue uses:

- each ``<speech>`` is an utterance; its words are timed at the script's rate
  (:data:`mse.dialogue.script.CHARS_PER_SECOND`, punctuation alone a :data:`PAUSE_SECONDS` pause)
  (a mark's ``time``, which Greta reads too, pins the words around it), and the words under a
  ``<pitchaccent>`` are its stressed words;
- each ``<emotion>`` is an emotion episode from ``start`` to ``end`` (no ``end``: until the
  next emotion), at its ``intensity`` (default 1), its ``type`` mapped to a behaviour set by
  the name table (:mod:`mse.dialogue.inputs.common`).

Everything else is reported (docs/dialogue-inputs.md): functions mse does not play (W520),
attributes it does not use (W521), emotion types without a set (W522), overlapping emotions
(W523), estimated word times (W524), functions Greta drops (W527).
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from lxml import etree

from mse.diagnostics import Diagnostic, MseError, Span
from mse.dialogue.inputs.common import (
    EmotionInterval,
    EmotionNames,
    InputEvent,
    InputReading,
    finish,
    known_emotion,
    load_emotion_names,
    load_xml,
    localname,
    resolve_emotion,
    sequence_emotions,
)
from mse.dialogue.script import CHARS_PER_SECOND
from mse.limits import MAX_SECONDS
from mse.syntax.safexml import XmlDocument

FORMAT = "fml-apml"
#: A token without a letter or digit (``.``, ``!``, ``...``) is a pause of this length.
PAUSE_SECONDS = 0.3

_REFERENCE = re.compile(r"^(?P<target>[^:\s]+):(?P<sync>[^\s+]+?)\s*(?:(?P<sign>[+-])\s*(?P<offset>[0-9.eE]+))?$")


@dataclass(frozen=True, slots=True)
class TimeRef:
    """A function's ``start`` or ``end``: a sync point plus an offset, or seconds."""

    target: str | None  # "s1:tm3", "e1:end"; None: ``offset`` is a time in seconds
    offset: float
    span: Span

    def greta(self) -> str:
        """As Greta's reader prints it (``s1:tm3 + 0.0``, ``5.0``)."""
        if self.target is None:
            return repr(float(self.offset))
        return f"{self.target} + {float(self.offset)!r}"


@dataclass(frozen=True, slots=True)
class Token:
    text: str
    start: float
    stop: float
    is_word: bool


@dataclass(frozen=True, slots=True)
class FmlSpeech:
    id: str
    start: float
    text: str  # the spoken text, white space collapsed
    marks: tuple[str, ...]  # "start", the <tm> ids in order, "end" (Greta's time_markers)
    mark_times: Mapping[str, float]
    tokens: tuple[Token, ...]
    stressed: tuple[int, ...]  # indices into the words
    span: Span

    @property
    def words(self) -> tuple[Token, ...]:
        return tuple(t for t in self.tokens if t.is_word)


@dataclass(frozen=True, slots=True)
class FmlFunction:
    """One child of ``<fml>`` (Greta's intention), as Greta reads it."""

    name: str  # the element: emotion, performative, certainty, ...
    id: str
    type: str
    start: TimeRef | None
    end: TimeRef | None
    importance: float
    intensity: float | None  # emotion, certainty, laugh
    regulation: str | None  # emotion
    span: Span


@dataclass(frozen=True)
class FmlDocument:
    path: str
    composition: str
    speeches: tuple[FmlSpeech, ...]
    functions: tuple[FmlFunction, ...]
    warnings: tuple[Diagnostic, ...]
    root_span: Span

    def time_of(self, ref: TimeRef, depth: int = 0) -> float | None:
        """Seconds of ``ref``; None when it names no sync point of the file."""
        if ref.target is None:
            return ref.offset
        target, _, sync = ref.target.partition(":")
        for speech in self.speeches:
            if speech.id == target and sync in speech.mark_times:
                return speech.mark_times[sync] + ref.offset
        if depth > len(self.functions):  # a cycle of references
            return None
        for function in self.functions:
            if function.id == target and sync in ("start", "end"):
                inner = function.start if sync == "start" else function.end
                found = self.time_of(inner, depth + 1) if inner is not None else None
                return None if found is None else found + ref.offset
        return None


_INTENSITY_OF = ("emotion", "certainty", "laugh")  # Greta's intention classes that carry one
_ALWAYS_USED = {"id"}


def _number(text: str, span: Span, what: str, errors: list[Diagnostic]) -> float | None:
    try:
        value = float(text)
    except ValueError:
        errors.append(Diagnostic("E152", f"{what} {text!r} is not a number", span))
        return None
    if not math.isfinite(value):
        errors.append(Diagnostic("E152", f"{what} {text!r} is not a finite number", span))
        return None
    return value


def _time_ref(text: str, span: Span, errors: list[Diagnostic]) -> TimeRef | None:
    text = text.strip()
    match = _REFERENCE.match(text)
    if match:
        offset = 0.0
        if match.group("offset"):
            value = _number(match.group("offset"), span, "offset", errors)
            if value is None:
                return None
            offset = -value if match.group("sign") == "-" else value
        return TimeRef(f"{match.group('target')}:{match.group('sync')}", offset, span)
    value = _number(text, span, "time", errors)
    if value is None:
        return None
    if not 0 <= value <= MAX_SECONDS:
        errors.append(Diagnostic("E152", f"time {text!r} is outside [0, {MAX_SECONDS:g}] seconds", span))
        return None
    return TimeRef(None, value, span)


def _unused_attributes(doc: XmlDocument, element: etree._Element, used: Iterable[str], label: str) -> list[Diagnostic]:
    names = [str(n) for n in element.attrib if str(n) not in set(used) | _ALWAYS_USED]
    if not names:
        return []
    listed = ", ".join(f"{n}={element.get(n)!r}" for n in names)
    return [Diagnostic("W521", f"{label}: not used by mse: {listed}", doc.attribute_span(element, names[0]))]


def _tokens(parts: list[tuple[str, str | None]], start: float) -> tuple[list[Token], list[int]]:
    """Tokens of the speech text timed at the estimated rate, and for each text part the index
    of its first token (a mark sits before that token)."""
    tokens: list[Token] = []
    first: list[int] = []
    clock = start
    for text, _ in parts:
        first.append(len(tokens))
        for word in text.split():
            is_word = any(c.isalnum() for c in word)
            length = (len(word) + 1) / CHARS_PER_SECOND if is_word else PAUSE_SECONDS
            tokens.append(Token(word, clock, clock + length, is_word))
            clock += length
    return tokens, first


def _pin(tokens: list[Token], anchors: list[tuple[float, float]]) -> list[Token]:
    """Move estimated times onto given mark times: piecewise linear between anchors
    ``(estimated, given)``, shifted after the last one."""
    if not anchors:
        return tokens
    anchors = sorted(anchors)

    def move(t: float) -> float:
        if t <= anchors[0][0]:
            return anchors[0][1] + (t - anchors[0][0])
        for (e0, g0), (e1, g1) in itertools.pairwise(anchors):
            if e0 <= t <= e1:
                return g0 if e1 == e0 else g0 + (t - e0) * (g1 - g0) / (e1 - e0)
        return anchors[-1][1] + (t - anchors[-1][0])

    return [Token(t.text, move(t.start), move(t.stop), t.is_word) for t in tokens]


def _read_speech(
    doc: XmlDocument, node: etree._Element, errors: list[Diagnostic], warnings: list[Diagnostic]
) -> FmlSpeech | None:
    span = doc.span(node)
    sid = (node.get("id") or "").strip()
    if not sid:
        errors.append(Diagnostic("E150", "<speech> needs an id (its time marks are referred to as id:tm)", span))
        return None
    start = 0.0
    if node.get("start") is not None:
        ref = _time_ref(node.get("start") or "", doc.attribute_span(node, "start"), errors)
        if ref is None:
            return None
        if ref.target is not None:
            errors.append(
                Diagnostic("E151", f"speech {sid!r}: start {node.get('start')!r} must be a number of seconds", ref.span)
            )
            return None
        start = ref.offset
    warnings += _unused_attributes(doc, node, ("start", "text"), f"speech {sid!r}")
    # Text parts, each preceded by the mark that opens it (None before the first mark).
    parts: list[tuple[str, str | None]] = [(node.text or "", None)]
    given: dict[str, float] = {}
    accents: list[etree._Element] = []
    for child in node:
        if not isinstance(child.tag, str):
            parts.append((child.tail or "", None))
            continue
        name = localname(child)
        if name == "tm":
            mid = (child.get("id") or "").strip()
            if not mid:
                warnings.append(
                    Diagnostic(
                        "W520", f"speech {sid!r}: <tm> without an id is ignored (as Greta does)", doc.span(child)
                    )
                )
                parts.append((child.tail or "", None))
                continue
            parts.append((child.tail or "", mid))
            if child.get("time") is not None:
                value = _number(child.get("time") or "", doc.attribute_span(child, "time"), "time", errors)
                if value is not None:
                    given[mid] = value
            warnings += _unused_attributes(doc, child, ("time",), f"time mark {sid}:{mid}")
        elif name == "pitchaccent":
            accents.append(child)
            parts.append((child.tail or "", None))
        else:
            what = {"boundary": "prosodic boundary", "description": "audio/phoneme reference"}.get(name, "element")
            warnings.append(
                Diagnostic("W520", f"speech {sid!r}: <{name}> ({what}) is not used by mse", doc.span(child))
            )
            parts.append((child.tail or "", None))
    tokens, first = _tokens(parts, start)
    end_estimate = tokens[-1].stop if tokens else start

    def estimated(index: int) -> float:
        return tokens[index].start if index < len(tokens) else end_estimate

    marks = [mark for _, mark in parts if mark is not None]
    anchors = [(estimated(first[i]), given[mark]) for i, (_, mark) in enumerate(parts) if mark in given]
    if anchors:
        tokens = _pin(tokens, anchors)
    elif tokens:
        warnings.append(
            Diagnostic(
                "W524",
                f"speech {sid!r}: its marks carry no time, so word times are estimated at "
                f"{CHARS_PER_SECOND:g} characters per second (a TTS gives the real ones)",
                span,
            )
        )
    times = {"start": tokens[0].start if tokens else start}
    for index, (_, mark) in enumerate(parts):
        if mark is not None and mark not in times:
            at = first[index]
            times[mark] = tokens[at].start if at < len(tokens) else (tokens[-1].stop if tokens else start)
    times["end"] = tokens[-1].stop if tokens else start
    text = " ".join(t.text for t in tokens)
    given_text = (node.get("text") or "").strip()
    if given_text and " ".join(given_text.split()) != text:
        warnings.append(
            Diagnostic(
                "W521",
                f"speech {sid!r}: the text attribute differs from the spoken text; mse uses the spoken text",
                doc.attribute_span(node, "text"),
            )
        )
    speech = FmlSpeech(sid, start, text, ("start", *marks, "end"), times, tuple(tokens), (), span)
    return speech if not accents else _with_stress(doc, speech, accents, errors, warnings)


def _with_stress(
    doc: XmlDocument,
    speech: FmlSpeech,
    accents: list[etree._Element],
    errors: list[Diagnostic],
    warnings: list[Diagnostic],
) -> FmlSpeech:
    """The words that start inside a pitch accent are stressed."""
    partial = FmlDocument(doc.path, "", (speech,), (), (), doc.span(doc.root))
    stressed: set[int] = set()
    for accent in accents:
        label = f"pitch accent {accent.get('id') or '?'!r}"
        warnings += _unused_attributes(doc, accent, ("start", "end"), label)
        refs = []
        for key in ("start", "end"):
            ref = _time_ref(accent.get(key) or "", doc.attribute_span(accent, key), errors) if accent.get(key) else None
            refs.append(None if ref is None else partial.time_of(ref))
        begin, finish_at = refs
        if begin is None:
            warnings.append(
                Diagnostic(
                    "W520", f"{label}: its start names no mark of speech {speech.id!r}; not used", doc.span(accent)
                )
            )
            continue
        stop = finish_at if finish_at is not None else begin + 1e-9
        stressed.update(i for i, w in enumerate(speech.words) if begin - 1e-9 <= w.start < stop)
    return FmlSpeech(
        speech.id,
        speech.start,
        speech.text,
        speech.marks,
        speech.mark_times,
        speech.tokens,
        tuple(sorted(stressed)),
        speech.span,
    )


def _read_function(
    doc: XmlDocument, node: etree._Element, errors: list[Diagnostic], warnings: list[Diagnostic]
) -> FmlFunction | None:
    name = localname(node)
    span = doc.span(node)
    fid = node.get("id") or ""
    if not fid:
        warnings.append(Diagnostic("W527", f"<{name}> without an id: Greta drops it, and so does mse", span))
        return None
    kind = node.get("type") or ""
    if name == "laugh":
        kind = kind or "laugh"  # Greta's LaughIntention has that type whatever the file says
    elif not kind and name != "deictic":
        warnings.append(
            Diagnostic(
                "W527",
                f"<{name} id={fid!r}> without a type: Greta's reader makes nothing of it "
                "(a null intention), and neither does mse",
                span,
            )
        )
        return None
    refs: list[TimeRef | None] = []
    for key in ("start", "end"):
        value = node.get(key)
        refs.append(_time_ref(value, doc.attribute_span(node, key), errors) if value else None)
    importance = 0.5
    if node.get("importance") is not None:
        importance = (
            _number(node.get("importance") or "", doc.attribute_span(node, "importance"), "importance", errors) or 0.0
        )
    intensity: float | None = None
    if name in _INTENSITY_OF:
        intensity = 1.0
        if node.get("intensity") is not None:
            where = doc.attribute_span(node, "intensity")
            level = _number(node.get("intensity") or "", where, "intensity", errors)
            if level is not None and not 0 <= level <= 1:
                errors.append(Diagnostic("E152", f"intensity {level:g} is outside [0, 1]", where))
            intensity = level if level is not None else 1.0
    regulation = (node.get("regulation") or "felt") if name == "emotion" else None
    return FmlFunction(name, fid, kind, refs[0], refs[1], importance, intensity, regulation, span)


def read_fml_document(source: str | Path | XmlDocument) -> FmlDocument:
    """The file as Greta reads it; MseError (E1xx) for what cannot be read."""
    doc = source if isinstance(source, XmlDocument) else load_xml(source, what="FML-APML file")
    root = doc.root
    errors: list[Diagnostic] = []
    warnings: list[Diagnostic] = []
    if localname(root) != "fml-apml":
        raise MseError([Diagnostic("E150", f"root element <{localname(root)}> is not <fml-apml>", doc.span(root))])
    warnings += _unused_attributes(doc, root, (), "<fml-apml>")
    speeches: list[FmlSpeech] = []
    functions: list[FmlFunction] = []
    for part in root:
        if not isinstance(part.tag, str):
            continue
        name = localname(part)
        if name == "bml":
            for child in part:
                if not isinstance(child.tag, str):
                    continue
                if localname(child) == "speech":
                    speech = _read_speech(doc, child, errors, warnings)
                    if speech is not None:
                        speeches.append(speech)
                else:
                    warnings.append(
                        Diagnostic(
                            "W520",
                            f"<bml> behaviour <{localname(child)}> is not used by mse (only the speech is)",
                            doc.span(child),
                        )
                    )
        elif name == "fml":
            for child in part:
                if isinstance(child.tag, str):
                    function = _read_function(doc, child, errors, warnings)
                    if function is not None:
                        functions.append(function)
        else:
            warnings.append(
                Diagnostic("W520", f"<{name}> is not part of FML-APML (<bml>, <fml>); not used", doc.span(part))
            )
    if errors:
        raise MseError(errors)
    seen: set[str] = set()
    for speech in speeches:
        if speech.id in seen:
            raise MseError([Diagnostic("E150", f"two speeches have the id {speech.id!r}", speech.span)])
        seen.add(speech.id)
    composition = (root.get("composition") or "blend").lower()
    return FmlDocument(doc.path, composition, tuple(speeches), tuple(functions), tuple(warnings), doc.span(root))


def say_event(speech: FmlSpeech) -> InputEvent | None:
    words = speech.words
    if not words:
        return None
    event: dict[str, Any] = {
        "t": round(words[0].start, 6),
        "say": " ".join(w.text for w in words),
        "words": [[w.text, round(w.start, 6), round(w.stop, 6)] for w in words],
    }
    stress = list(dict.fromkeys(words[i].text for i in speech.stressed))
    if stress:
        event["stress"] = stress
    return InputEvent(event, speech.span)


def read_fml(
    path: str | Path | XmlDocument,
    *,
    names: EmotionNames | None = None,
    known: Callable[[str, Span], bool] = known_emotion,
) -> InputReading:
    """Dialogue events of an FML-APML file, and what mse does not use of it."""
    document = read_fml_document(path)
    names = names or load_emotion_names()
    warnings = list(document.warnings)
    errors: list[Diagnostic] = []
    events: list[InputEvent] = []
    for speech in document.speeches:
        said = say_event(speech)
        if said is None:
            warnings.append(Diagnostic("W520", f"speech {speech.id!r} has no words; nothing is said", speech.span))
        else:
            events.append(said)
    intervals: list[EmotionInterval] = []
    for function in document.functions:
        label = f"<{function.name} id={function.id!r} type={function.type!r}>"
        if function.name != "emotion":
            warnings.append(
                Diagnostic("W520", f"{label}: mse plays emotions only; this function is not used", function.span)
            )
            continue
        if function.start is None:
            errors.append(Diagnostic("E150", f"{label} has no start", function.span))
            continue
        times: list[float | None] = []
        for ref in (function.start, function.end):
            if ref is None:
                times.append(None)
                continue
            value = document.time_of(ref)
            if value is None:
                marks = ", ".join(f"{s.id}:{m}" for s in document.speeches for m in s.marks[:6])
                errors.append(
                    Diagnostic(
                        "E151",
                        f"{label}: {ref.target!r} names no time mark nor function of the "
                        f"file (marks: {marks or 'none'})",
                        ref.span,
                    )
                )
            times.append(value)
        start, stop = times
        if start is None or (function.end is not None and stop is None):
            continue
        if stop is not None and stop <= start:
            errors.append(
                Diagnostic(
                    "E152",
                    f"{label} ends at {stop:g} s, not after its start {start:g} s",
                    function.end.span if function.end else function.span,
                )
            )
            continue
        if function.regulation not in (None, "felt"):
            warnings.append(
                Diagnostic(
                    "W521",
                    f"{label}: regulation={function.regulation!r} is not used; mse plays the felt expression",
                    function.span,
                )
            )
        if function.importance != 0.5:
            warnings.append(
                Diagnostic("W521", f"{label}: importance={function.importance:g} is not used", function.span)
            )
        emotion = resolve_emotion(names, FORMAT, function.type, function.span, known, warnings)
        if emotion is None:
            continue
        intensity = function.intensity if function.intensity is not None else 1.0
        intervals.append(EmotionInterval(emotion, intensity, start, stop, function.span, label))
    if errors:
        raise MseError(errors)
    events += sequence_emotions(intervals, warnings)
    return finish(FORMAT, events, warnings, document.root_span)

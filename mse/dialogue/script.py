"""Dialogue scripts: the events of a conversation, one JSON object per line (JSON Lines).

```
{"t": 0.0, "emotion": "anger", "intensity": 0.8, "until": 3.7}
{"t": 0.4, "say": "I can't believe it", "words": [["I", 0.4, 0.52], ["can't", 0.52, 0.8], ...], "stress": ["believe"]}
{"t": 8.7, "end": true}
```

An *emotion* event starts an episode of that emotion (a bundled name or a behaviour-set file;
a relative path is looked up next to the script first) with an intensity in [0, 1] (default 1);
``until`` announces when it ends.  A *say* event is an utterance: its words with their start and
stop (as TTS engines report them; estimated from the text at :data:`CHARS_PER_SECOND` without
them) and its stressed words.  ``end`` closes the dialogue.  The JSON Schema is
``mse/dialogue/script.schema.json``; the meaning is in docs/dialogue.md.

Other readers (FML-APML, EmotionML) produce the same dicts and call :func:`parse_event`, then
:func:`check_sequence` for what only the whole sequence shows (order, overlapping utterances).
Every problem is an :class:`~mse.diagnostics.MseError` with code E217 at ``file:line``.
"""

from __future__ import annotations

import difflib
import math
import os
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mse.diagnostics import Diagnostic, MseError, Span
from mse.limits import MAX_SECONDS, xml_char_problem

CODE = "E217"
#: Speaking rate for utterances without word timings: characters per second, a word's space
#: included (about 165 words a minute for English words of 5 letters, an ordinary TTS rate).
CHARS_PER_SECOND = 14.0
#: Keys of each kind of event (the schema's ``properties``).
EMOTION_KEYS = frozenset({"t", "emotion", "intensity", "until"})
SAY_KEYS = frozenset({"t", "say", "words", "stress"})
END_KEYS = frozenset({"t", "end"})
_NOWHERE = Span("<script>")
#: The grid of timelines (1 ms): times are rounded to it when read.
_GRID = 1000


@dataclass(frozen=True, slots=True)
class Word:
    """One spoken word and its time span (seconds, absolute in the dialogue)."""

    text: str
    start: float
    stop: float


@dataclass(frozen=True, slots=True)
class EmotionEvent:
    """From ``t`` the agent expresses ``emotion`` at ``intensity``; ``until`` when announced."""

    t: float
    emotion: str
    intensity: float = 1.0
    until: float | None = None
    span: Span = _NOWHERE


@dataclass(frozen=True, slots=True)
class SayEvent:
    """An utterance starting at ``t``: words in order, within [t, stop]."""

    t: float
    text: str
    words: tuple[Word, ...]
    stress: tuple[str, ...] = ()
    span: Span = _NOWHERE

    @property
    def stop(self) -> float:
        return self.words[-1].stop if self.words else self.t

    def stressed_words(self) -> tuple[Word, ...]:
        """The words marked as stressed (each occurrence of a stressed text)."""
        marked = {s.casefold() for s in self.stress}
        return tuple(w for w in self.words if _bare(w.text).casefold() in marked or w.text.casefold() in marked)


@dataclass(frozen=True, slots=True)
class EndEvent:
    """The dialogue ends at ``t``."""

    t: float
    span: Span = _NOWHERE


Event = EmotionEvent | SayEvent | EndEvent


def _fail(message: str, span: Span) -> MseError:
    return MseError([Diagnostic(CODE, message, span)])


def _round(value: float) -> float:
    return round(value * _GRID) / _GRID


def _bare(word: str) -> str:
    """A word without surrounding punctuation ("that," -> "that")."""
    return word.strip(".,;:!?\"'()[]{}«»“”‘’…-")


def _time(obj: Mapping[str, Any], key: str, span: Span, *, required: bool = True) -> float | None:
    value = obj.get(key)
    if value is None:
        if required:
            raise _fail(f"'{key}' is required: a time in seconds", span)
        return None
    if not isinstance(value, int | float) or isinstance(value, bool) or not math.isfinite(value):
        raise _fail(f"'{key}' must be a number of seconds, not {value!r}", span)
    if not 0 <= value <= MAX_SECONDS:
        raise _fail(f"'{key}' {value:g} is outside [0, {MAX_SECONDS:g}] seconds", span)
    return _round(float(value))


def _text(value: Any, what: str, span: Span) -> str:
    if not isinstance(value, str):
        raise _fail(f"{what} must be a string, not {value!r}", span)
    problem = xml_char_problem(value)
    if problem is not None:
        raise _fail(f"{what} {problem}", span)
    return value


def _check_keys(obj: Mapping[str, Any], allowed: frozenset[str], kind: str, span: Span) -> None:
    for key in obj:
        if key not in allowed:
            guess = difflib.get_close_matches(str(key), sorted(allowed), n=1, cutoff=0.6)
            hint = f" (did you mean {guess[0]!r}?)" if guess else ""
            raise _fail(f"unknown key {key!r} in {kind} event{hint}; allowed: {', '.join(sorted(allowed))}", span)


def resolve_emotion(name: str, span: Span) -> Path:
    """The behaviour-set file of ``name``: a file next to the script, a path, or a bundled name;
    E217 with did-you-mean over the bundled names otherwise."""
    from mse.api import resolve_path

    if span.path and not span.path.startswith("<") and not os.path.isabs(name):
        beside = Path(span.path).parent / name
        if beside.is_file():
            return beside
    try:
        return resolve_path(name)
    except MseError as error:
        message = error.diagnostics[0].message if error.diagnostics else "unknown emotion"
        raise _fail(f"unknown emotion {name!r}: {message}", span) from None


def estimate_words(text: str, start: float) -> tuple[Word, ...]:
    """Word timings for ``text`` spoken from ``start`` at :data:`CHARS_PER_SECOND`."""
    words = []
    at = start
    for token in text.split():
        length = (len(token) + 1) / CHARS_PER_SECOND
        words.append(Word(token, _round(at), _round(at + length)))
        at += length
    return tuple(words)


def _words(raw: Any, t: float, span: Span) -> tuple[Word, ...]:
    if not isinstance(raw, list):
        raise _fail("'words' must be a list of [word, start, stop]", span)
    words: list[Word] = []
    for index, entry in enumerate(raw):
        if (
            not isinstance(entry, list)
            or len(entry) != 3
            or not isinstance(entry[0], str)
            or not all(isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x) for x in entry[1:])
        ):
            raise _fail(f"words[{index}] must be [word, start, stop] (a string and two numbers), not {entry!r}", span)
        text = _text(entry[0], f"words[{index}]", span)
        start, stop = _round(float(entry[1])), _round(float(entry[2]))
        if not 0 <= start <= MAX_SECONDS or not 0 <= stop <= MAX_SECONDS:
            raise _fail(f"words[{index}] ({text!r}) has a time outside [0, {MAX_SECONDS:g}] seconds", span)
        if stop < start:
            raise _fail(f"words[{index}] ({text!r}) stops at {stop:g} s, before its start {start:g} s", span)
        if start < t:
            raise _fail(
                f"words[{index}] ({text!r}) starts at {start:g} s, before its utterance (t = {t:g} s): "
                "words lie within their utterance",
                span,
            )
        if words and start < words[-1].stop:
            raise _fail(
                f"words[{index}] ({text!r}) starts at {start:g} s, before the previous word "
                f"({words[-1].text!r}) stops at {words[-1].stop:g} s: words are in order and do not overlap",
                span,
            )
        words.append(Word(text, start, stop))
    return tuple(words)


def parse_event(obj: Any, span: Span) -> Event:
    """One event from its decoded JSON object (a script line, or a dict another reader made).

    Raises MseError (E217 at ``span``) with a clear message when the object is not an event."""
    if not isinstance(obj, dict):
        raise _fail("an event must be a JSON object such as {\"t\": 0.0, \"emotion\": \"anger\"}", span)
    kinds = [key for key in ("emotion", "say", "end") if key in obj]
    if len(kinds) != 1:
        found = f"it has {' and '.join(repr(k) for k in kinds)}" if kinds else "it has none"
        hint = ""
        for key in obj if not kinds else ():
            guess = difflib.get_close_matches(str(key), ["emotion", "say", "end"], n=1, cutoff=0.6)
            if guess:
                hint = f" (unknown key {key!r}: did you mean {guess[0]!r}?)"
                break
        raise _fail(f"an event has exactly one of 'emotion', 'say' or 'end': {found}{hint}", span)
    kind = kinds[0]
    t = _time(obj, "t", span)
    assert t is not None
    if kind == "end":
        _check_keys(obj, END_KEYS, "an end", span)
        if obj["end"] is not True:
            raise _fail(f"'end' must be true, not {obj['end']!r}", span)
        return EndEvent(t, span)
    if kind == "emotion":
        _check_keys(obj, EMOTION_KEYS, "an emotion", span)
        name = _text(obj["emotion"], "'emotion'", span)
        if not name.strip():
            raise _fail("'emotion' is empty: give a bundled name or a behaviour-set file", span)
        resolve_emotion(name, span)
        intensity = obj.get("intensity", 1.0)
        if (
            not isinstance(intensity, int | float)
            or isinstance(intensity, bool)
            or not math.isfinite(intensity)
            or not 0 <= intensity <= 1
        ):
            raise _fail(f"'intensity' must be a number in [0, 1], not {intensity!r}", span)
        until = _time(obj, "until", span, required=False)
        if until is not None and until <= t:
            raise _fail(f"'until' {until:g} s must be after the event's time t = {t:g} s", span)
        return EmotionEvent(t, name, float(intensity), until, span)
    _check_keys(obj, SAY_KEYS, "a say", span)
    text = _text(obj["say"], "'say'", span)
    if not text.strip():
        raise _fail("'say' is empty: an utterance has words", span)
    words = _words(obj["words"], t, span) if "words" in obj else estimate_words(text, t)
    if not words:
        raise _fail("'words' is empty: an utterance has words", span)
    raw_stress = obj.get("stress", [])
    if not isinstance(raw_stress, list) or not all(isinstance(s, str) for s in raw_stress):
        raise _fail("'stress' must be a list of words of the utterance", span)
    spoken = {_bare(w.text).casefold() for w in words} | {w.text.casefold() for w in words}
    for marked in raw_stress:
        if marked.casefold() not in spoken:
            guess = difflib.get_close_matches(marked, sorted({w.text for w in words}), n=1, cutoff=0.6)
            hint = f" (did you mean {guess[0]!r}?)" if guess else ""
            raise _fail(f"stressed word {marked!r} is not among the utterance's words{hint}", span)
    return SayEvent(t, text, words, tuple(raw_stress), span)


def check_sequence(events: Sequence[Event]) -> None:
    """What only the whole script shows: events in time order, utterances not overlapping, an
    emotion first, nothing after the end, an announced end not after the dialogue's end."""
    previous: Event | None = None
    speaking: SayEvent | None = None
    ended: EndEvent | None = None
    for event in events:
        if ended is not None:
            raise _fail(f"event after the dialogue's end (line {ended.span.line}, t = {ended.t:g} s)", event.span)
        if previous is not None and event.t < previous.t:
            raise _fail(
                f"events out of order: t = {event.t:g} s comes after an event at t = {previous.t:g} s "
                f"({_where(previous.span)}); events are in time order",
                event.span,
            )
        if isinstance(event, SayEvent):
            if speaking is not None and event.t < speaking.stop:
                raise _fail(
                    f"utterance at t = {event.t:g} s overlaps the previous one ({_where(speaking.span)}), "
                    f"which speaks until {speaking.stop:g} s",
                    event.span,
                )
            speaking = event
        if isinstance(event, EndEvent):
            ended = event
        previous = event
    if events and not isinstance(events[0], EmotionEvent) and not isinstance(events[0], EndEvent):
        first_emotion = next((e for e in events if isinstance(e, EmotionEvent)), None)
        if first_emotion is None or first_emotion.t > events[0].t:
            raise _fail("the script's first event must be an emotion (which face speaks?)", events[0].span)
    if ended is not None:
        for event in events:
            if isinstance(event, SayEvent) and event.stop > ended.t:
                message = f"utterance speaks until {event.stop:g} s, after the dialogue's end at {ended.t:g} s"
                raise _fail(message, event.span)


def _where(span: Span) -> str:
    return f"line {span.line}" if span.line else span.render()


def parse_events(objects: Iterable[tuple[Any, Span]]) -> list[Event]:
    """Events from (object, span) pairs, checked one by one and as a sequence."""
    events = [parse_event(obj, span) for obj, span in objects]
    check_sequence(events)
    return events


_BLANK = re.compile(r"\s*")


def read_script(path: str | os.PathLike[str]) -> list[Event]:
    """The events of a JSON Lines script (``-``: standard input); MseError at ``file:line``."""
    from mse.input_files import decode_utf8, parse_json, read_input

    name = os.fspath(path)
    shown = "<stdin>" if name == "-" else name
    text = decode_utf8(read_input(path, what="dialogue script"), shown, code=CODE, what="dialogue script")
    objects: list[tuple[Any, Span]] = []
    for number, line in enumerate(text.split("\n"), start=1):
        if _BLANK.fullmatch(line):
            continue
        objects.append((parse_json(line, shown, code=CODE, line=number), Span(shown, number, 1)))
    if not objects:
        raise _fail("the script has no events (one JSON object per line)", Span(shown, 1, 1))
    return parse_events(objects)

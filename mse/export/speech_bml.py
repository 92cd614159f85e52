"""BML with speech sync: a dialogue's utterances as ``<speech>`` with a sync point at every word
boundary, and behaviours tied to them where mse planned them on a boundary.

A realizer times speech with its own TTS, which never matches the times mse planned with exactly;
a behaviour that refers to ``speech1:w3`` moves with the third word wherever the TTS puts it.  So a
behaviour's ``start`` or ``end`` that lies on a word boundary (within :data:`SYNC_TOLERANCE`, as an
anchor to a word places it) is written as a sync reference; any other time stays a number.

Sync points of utterance *n* (``speech<n>``, numbered from 1 in the dialogue): ``w<i>`` just
before word *i* (its start) and ``e<i>`` just after it (its stop) where a pause follows or it is
the last word.  Profiles:

- BML 1.0 (``generic``, ``asap``): ``<speech id start><text><sync id="w1"/>I <sync id="w2"/>can't
  ...<sync id="e6"/></text></speech>`` (BML 1.0 core; AsapRealizer's parser keeps the syncs);
- Greta (``greta-bml``, ``bml --realizer greta``): ``<speech id start end text=""><tm id="w1"
  time="0.4"/>I <tm .../>...</speech>``, Greta's own time markers, whose ``time`` Greta reads
  (so its Temporizer resolves ``speech1:w3`` even without a TTS), and a ``<pitchaccent>`` over
  each stressed word.

The input is minimal so that any timeline fits (:class:`Occurrence`: a TimelineSignal is one):
the utterances and the occurrences, with times in seconds in the block's time base.
"""

from __future__ import annotations

import bisect
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any, Protocol

from mse.export.lexemes import format_seconds
from mse.export.xmltext import Comment, Element, element

#: A behaviour time this close to a word boundary is written as a reference to it (seconds):
#: timelines and word timings are on the same 1 ms grid, so a behaviour anchored to a word
#: lies exactly on it, and a time that merely falls near a word is not tied to it.
SYNC_TOLERANCE = 0.001


class Occurrence(Protocol):
    """What speech sync needs of an occurrence (``mse.timeline.TimelineSignal`` has it)."""

    @property
    def id(self) -> str: ...
    @property
    def lexeme(self) -> str: ...
    @property
    def start(self) -> float: ...
    @property
    def stop(self) -> float: ...
    @property
    def modality(self) -> str: ...
    @property
    def episode(self) -> int | None: ...


@dataclass(frozen=True, slots=True)
class SpokenWord:
    text: str
    start: float
    stop: float


@dataclass(frozen=True, slots=True)
class Utterance:
    start: float
    stop: float
    text: str
    words: tuple[SpokenWord, ...]
    stress: tuple[str, ...] = ()

    def stressed(self, word: SpokenWord) -> bool:
        marked = {s.casefold() for s in self.stress}
        bare = word.text.strip(".,;:!?\"'()[]{}«»“”‘’…-").casefold()
        return bare in marked or word.text.casefold() in marked


def utterances_from_json(entries: Iterable[Mapping[str, Any]]) -> list[Utterance]:
    """The ``utterances`` of a dialogue timeline's JSON (``{start, stop, text, words, stress}``)."""
    found = []
    for entry in entries:
        words = tuple(SpokenWord(str(w[0]), float(w[1]), float(w[2])) for w in entry.get("words", []))
        found.append(
            Utterance(
                float(entry.get("start", words[0].start if words else 0.0)),
                float(entry.get("stop", words[-1].stop if words else 0.0)),
                str(entry.get("text", " ".join(w.text for w in words))),
                words,
                tuple(str(s) for s in entry.get("stress", [])),
            )
        )
    return found


@dataclass(frozen=True, slots=True)
class SyncPoint:
    speech: str  # the <speech> id
    sync: str  # w3, e6
    time: float

    @property
    def reference(self) -> str:
        return f"{self.speech}:{self.sync}"


@dataclass(frozen=True)
class SpeechSync:
    """The speech of one block: its elements, its sync points, and the references made."""

    utterances: tuple[tuple[str, Utterance], ...]  # (speech id, utterance)
    points: tuple[SyncPoint, ...]  # sorted by time

    def at(self, time: float) -> SyncPoint | None:
        """The sync point on ``time`` (within the tolerance), the earliest of equals."""
        times = [p.time for p in self.points]
        index = bisect.bisect_left(times, time - SYNC_TOLERANCE - 1e-9)
        if index < len(self.points) and abs(self.points[index].time - time) <= SYNC_TOLERANCE + 1e-9:
            return self.points[index]
        return None


def speech_sync(utterances: Sequence[Utterance], taken: Iterable[str] = (), *, origin: float = 0.0) -> SpeechSync:
    """Speech ids (``speech1``…, never one of ``taken``) and the sync points of ``utterances``,
    times counted from ``origin``."""
    used = set(taken)
    named: list[tuple[str, Utterance]] = []
    points: list[SyncPoint] = []
    for number, utterance in enumerate(utterances, start=1):
        sid = f"speech{number}"
        while sid in used:
            sid += "_"
        used.add(sid)
        named.append((sid, utterance))
        words = utterance.words
        for index, word in enumerate(words, start=1):
            points.append(SyncPoint(sid, f"w{index}", round(word.start - origin, 6)))
            following = words[index] if index < len(words) else None
            if following is None or following.start - word.stop > SYNC_TOLERANCE:
                points.append(SyncPoint(sid, f"e{index}", round(word.stop - origin, 6)))
    points.sort(key=lambda p: p.time)  # stable: word starts before the stops that equal them
    return SpeechSync(tuple(named), tuple(points))


# -- the <speech> elements ------------------------------------------------------------------------
def _marks(sid: str, utterance: Utterance, mark: Any) -> list[Element | str]:
    """Text with a mark before each word and after each word a pause or the end follows."""
    parts: list[Element | str] = []
    words = utterance.words
    for index, word in enumerate(words, start=1):
        parts.append(mark(f"w{index}", word.start))
        following = words[index] if index < len(words) else None
        parts.append(word.text + ("" if following is None else " "))
        if following is None or following.start - word.stop > SYNC_TOLERANCE:
            parts.append(mark(f"e{index}", word.stop))
    return parts


def bml_speech(sync: SpeechSync, *, origin: float = 0.0) -> list[Element]:
    """BML 1.0 ``<speech>`` elements: ``<text>`` with ``<sync id>`` at the word boundaries."""
    speeches = []
    for sid, utterance in sync.utterances:
        marks = _marks(sid, utterance, lambda name, _t: element("sync", {"id": name}))
        text = Element("text", {}, tuple(marks), inline=True)
        speeches.append(element("speech", {"id": sid, "start": format_seconds(utterance.start - origin)}, text))
    return speeches


def greta_speech(sync: SpeechSync, *, origin: float = 0.0) -> list[Element]:
    """Greta ``<speech>`` elements: ``<tm id time>`` at the word boundaries, a ``<pitchaccent>``
    over each stressed word (Greta's TTS stresses it)."""
    speeches = []
    for sid, utterance in sync.utterances:

        def mark(name: str, time: float) -> Element:
            return element("tm", {"id": name, "time": format_seconds(time - origin)})

        parts: list[Element | str] = list(_marks(sid, utterance, mark))
        words = utterance.words
        for index, word in enumerate(words, start=1):
            if utterance.stressed(word):
                stop = (
                    f"e{index}"
                    if index == len(words) or words[index].start - word.stop > SYNC_TOLERANCE
                    else (f"w{index + 1}")
                )
                attrs = {
                    "id": f"{sid}_pa{index}",
                    "start": f"{sid}:w{index}",
                    "end": f"{sid}:{stop}",
                    "type": "Hstar",
                    "level": "medium",
                    "importance": "1",
                }
                parts.append(element("pitchaccent", attrs))
        attrs = {
            "id": sid,
            "start": format_seconds(utterance.start - origin),
            "end": format_seconds(utterance.stop - origin),
            "language": "english",
            "text": "",
        }
        speeches.append(Element("speech", attrs, tuple(parts), inline=True))
    return speeches


# -- behaviours tied to the speech ------------------------------------------------------------------
@dataclass(frozen=True)
class SyncedBlock:
    """A block's elements with references in place, and which references were made."""

    children: list[Element | Comment | str]
    references: dict[tuple[str, str], SyncPoint]  # (element id, "start"|"end") -> point


def tie_to_speech(
    children: Sequence[Element | Comment | str],
    times: Mapping[str, tuple[float, float]],
    sync: SpeechSync,
) -> SyncedBlock:
    """Replace each behaviour's numeric ``start``/``end`` by the sync point it lies on.

    ``times`` maps a written element id (``ext:faceFacs`` ids carry an ``_auN`` suffix, looked
    up without it) to the (start, stop) mse planned, in the block's time base."""
    references: dict[tuple[str, str], SyncPoint] = {}
    result: list[Element | Comment | str] = []
    for child in children:
        if not isinstance(child, Element) or "id" not in child.attributes:
            result.append(child)
            continue
        bid = str(child.attributes["id"])
        planned = times.get(bid) or times.get(bid.rpartition("_au")[0] if "_au" in bid else "")
        if planned is None:
            result.append(child)
            continue
        attributes = dict(child.attributes)
        for key, time in (("start", planned[0]), ("end", planned[1])):
            if key not in attributes:
                continue
            point = sync.at(time)
            if point is not None:
                attributes[key] = point.reference
                references[(bid, key)] = point
        result.append(replace(child, attributes=attributes))
    return SyncedBlock(result, references)


class _Planned(Protocol):
    @property
    def id(self) -> str: ...
    @property
    def signal(self) -> Occurrence: ...


def with_speech(
    utterances: Iterable[Mapping[str, Any]],
    behaviours: Sequence[_Planned],
    children: Sequence[Element | Comment | str],
    *,
    greta: bool,
    origin: float = 0.0,
) -> list[Element | Comment | str]:
    """A block's children with the utterances' ``<speech>`` first and the behaviours tied to
    them (the hook of :func:`mse.export.bml.render_bml` and ``render_greta_bml``)."""
    spoken = [u for u in utterances_from_json(utterances) if u.words]
    if not spoken:
        return list(children)
    sync = speech_sync(spoken, (b.id for b in behaviours), origin=origin)
    times = {b.id: (round(b.signal.start, 6), round(b.signal.stop, 6)) for b in behaviours}
    synced = tie_to_speech(children, times, sync)
    speech = greta_speech(sync, origin=origin) if greta else bml_speech(sync, origin=origin)
    return [*speech, *synced.children]

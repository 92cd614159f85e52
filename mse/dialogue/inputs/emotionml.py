"""W3C EmotionML 1.0, read into dialogue events.

Each ``<emotion>`` with a time becomes an emotion episode: ``start``/``end``/``duration`` are
milliseconds (absolute, since 1970, as the specification says: mse counts from the earliest
``start`` of the document), ``offset-to-start`` (+ ``duration``) counts from the start of the
``time-ref-uri`` it names.  Its ``<category>`` names the emotion in the declared vocabulary
(``category-set`` on the emotion or on ``<emotionml>``), mapped to a behaviour set by the name
table (:mod:`mse.dialogue.inputs.common`); the intensity is the W3C intensity dimension's value,
else the category's ``value``, else 1.

Checked as the EmotionML checker (``$MSE_SHARED/emotionml/check``) checks what mse uses: the
root, declared vocabularies and names in them (W3C and document-local vocabularies; others
are never fetched, W529), whole non-negative milliseconds, values in [0, 1].  Reported: what mse
does not use (dimensions other than intensity, appraisals, action tendencies, traces, references,
``<info>``: W520; ``confidence``, ``expressed-through``: W521), several categories in one
emotion (W525), emotions without a usable time (W526).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

from lxml import etree

from mse.diagnostics import Diagnostic, MseError, Span
from mse.dialogue.inputs.common import (
    EmotionInterval,
    EmotionNames,
    InputReading,
    finish,
    known_emotion,
    load_emotion_names,
    load_xml,
    localname,
    resolve_emotion,
    sequence_emotions,
)
from mse.syntax.safexml import XmlDocument

FORMAT = "emotionml"
NAMESPACE = "http://www.w3.org/2009/10/emotionml"
_SETS = {
    "category": "category-set",
    "dimension": "dimension-set",
    "appraisal": "appraisal-set",
    "action-tendency": "action-tendency-set",
}
_EMOTION_ATTRIBUTES = {
    "category-set",
    "dimension-set",
    "appraisal-set",
    "action-tendency-set",
    "start",
    "end",
    "duration",
    "offset-to-start",
    "time-ref-uri",
    "time-ref-anchor-point",
    "version",
}


@dataclass(frozen=True, slots=True)
class Timing:
    """An emotion's time in milliseconds: ``base`` None for clock times, else its time-ref-uri."""

    base: str | None
    start: int
    end: int | None


class _Reader:
    def __init__(self, doc: XmlDocument, names: EmotionNames, known: Callable[[str, Span], bool]) -> None:
        self.doc = doc
        self.names = names
        self.known = known
        self.errors: list[Diagnostic] = []
        self.warnings: list[Diagnostic] = []
        self.local: dict[str, tuple[str, set[str]]] = {}  # vocabulary id -> (type, names)
        self.unchecked: set[str] = set()  # category vocabularies reported as W529

    # -- values --------------------------------------------------------------------------------
    def integer(self, node: etree._Element, key: str, *, negative: bool = False) -> int | None:
        text = (node.get(key) or "").strip()
        try:
            value = int(text)
        except ValueError:
            value = None
        if value is None or (value < 0 and not negative):
            kind = "a whole number of milliseconds" + ("" if negative else " (not negative)")
            self.errors.append(
                Diagnostic("E152", f"{key}={node.get(key)!r} is not {kind}", self.doc.attribute_span(node, key))
            )
            return None
        return value

    def scale(self, node: etree._Element, key: str) -> float | None:
        if node.get(key) is None:
            return None
        where = self.doc.attribute_span(node, key)
        try:
            value = float(node.get(key) or "")
        except ValueError:
            value = float("nan")
        if not 0 <= value <= 1:
            self.errors.append(Diagnostic("E152", f"{key}={node.get(key)!r} is not a value in [0, 1]", where))
            return None
        return value

    # -- vocabularies ----------------------------------------------------------------------------
    def members(self, vocabulary: str, kind: str, where: Span) -> set[str] | None:
        """Names of ``vocabulary`` (None: mse cannot know them)."""
        if vocabulary.startswith("#"):
            found = self.local.get(vocabulary[1:])
            if found is None or found[0] != kind:
                self.errors.append(
                    Diagnostic(
                        "E150", f"{_SETS[kind]} {vocabulary!r} names no {kind} <vocabulary> of the document", where
                    )
                )
                return None
            return found[1]
        if kind != "category":  # mse uses no name of these: nothing to check
            return None
        table = self.names.table(vocabulary)
        if table is not None:
            return set(table)
        if vocabulary in self.unchecked:
            return None
        self.unchecked.add(vocabulary)
        self.warnings.append(
            Diagnostic(
                "W529",
                f"{_SETS[kind]} {vocabulary!r} is not a vocabulary mse knows (it never "
                "fetches one): its names are not checked",
                where,
            )
        )
        return None

    def vocabulary_of(self, emotion: etree._Element, kind: str) -> str | None:
        return emotion.get(_SETS[kind]) or self.doc.root.get(_SETS[kind])

    # -- the parts of an emotion -----------------------------------------------------------------------
    def descriptor(self, emotion: etree._Element, node: etree._Element, kind: str) -> tuple[str, float | None] | None:
        """(name, value) of a category/dimension/appraisal/action-tendency, checked."""
        where = self.doc.span(node)
        vocabulary = self.vocabulary_of(emotion, kind)
        name = node.get("name") or ""
        if vocabulary is None:
            self.errors.append(
                Diagnostic(
                    "E150",
                    f"<{kind}> used without declaring a {kind} vocabulary ({_SETS[kind]} on <emotion> or <emotionml>)",
                    where,
                )
            )
            return None
        members = self.members(vocabulary, kind, self.doc.span(emotion))
        if members is not None and name not in members:
            self.errors.append(
                Diagnostic(
                    "E150",
                    f"the name {name!r} of <{kind}> is not in the declared vocabulary {vocabulary!r}",
                    self.doc.attribute_span(node, "name"),
                )
            )
            return None
        value = self.scale(node, "value")
        self.scale(node, "confidence")
        if node.get("confidence") is not None:
            self.warnings.append(
                Diagnostic(
                    "W521",
                    f"<{kind} name={name!r}>: confidence is not used",
                    self.doc.attribute_span(node, "confidence"),
                )
            )
        for child in node:
            if isinstance(child.tag, str):
                self.warnings.append(
                    Diagnostic(
                        "W520",
                        f"<{kind} name={name!r}>: <{localname(child)}> (a value over time) is not used",
                        self.doc.span(child),
                    )
                )
        return name, value

    def timing(self, emotion: etree._Element, label: str) -> Timing | None:
        span = self.doc.span(emotion)
        if emotion.get("start") is not None or emotion.get("end") is not None:
            if emotion.get("start") is None:
                self.warnings.append(Diagnostic("W526", f"{label}: an end without a start; not placed", span))
                return None
            start = self.integer(emotion, "start")
            end = self.integer(emotion, "end") if emotion.get("end") is not None else None
            if end is None and emotion.get("duration") is not None and start is not None:
                duration = self.integer(emotion, "duration")
                end = None if duration is None else start + duration
            return None if start is None else Timing(None, start, end)
        if emotion.get("offset-to-start") is not None:
            anchor = emotion.get("time-ref-anchor-point") or "start"
            if anchor != "start":
                self.warnings.append(
                    Diagnostic(
                        "W526",
                        f"{label}: times from the end of {emotion.get('time-ref-uri')!r} "
                        "need its length, which mse does not know; not placed",
                        span,
                    )
                )
                return None
            offset = self.integer(emotion, "offset-to-start", negative=True)
            duration = self.integer(emotion, "duration") if emotion.get("duration") is not None else None
            if offset is None:
                return None
            if offset < 0:
                self.warnings.append(
                    Diagnostic("W526", f"{label}: starts {-offset} ms before its reference; not placed", span)
                )
                return None
            return Timing(emotion.get("time-ref-uri") or "", offset, None if duration is None else offset + duration)
        self.warnings.append(
            Diagnostic("W526", f"{label}: no start nor offset-to-start, so no place in time; not placed", span)
        )
        return None

    def emotion(self, emotion: etree._Element) -> tuple[Timing, EmotionInterval] | None:
        span = self.doc.span(emotion)
        version = emotion.get("version")
        if version is not None and version != "1.0":
            self.errors.append(
                Diagnostic(
                    "E150",
                    f"<emotion version={version!r}>: only 1.0 exists",
                    self.doc.attribute_span(emotion, "version"),
                )
            )
        unused = [k for k in map(str, emotion.attrib) if k not in _EMOTION_ATTRIBUTES and k != "id"]
        if unused:
            listed = ", ".join(f"{k}={emotion.get(k)!r}" for k in unused)
            self.warnings.append(
                Diagnostic("W521", f"<emotion>: not used by mse: {listed}", self.doc.attribute_span(emotion, unused[0]))
            )
        categories: list[tuple[str, float | None, Span]] = []
        intensity: float | None = None
        for child in emotion:
            if not isinstance(child.tag, str):
                continue
            kind = localname(child)
            if kind in _SETS:
                found = self.descriptor(emotion, child, kind)
                if found is None:
                    continue
                name, value = found
                if kind == "category":
                    categories.append((name, value, self.doc.span(child)))
                    continue
                vocabulary = self.vocabulary_of(emotion, kind) or ""
                if kind == "dimension" and name == self.names.intensity_dimension(vocabulary) and value is not None:
                    intensity = value
                    continue
                self.warnings.append(
                    Diagnostic(
                        "W520",
                        f"<{kind} name={name!r}>: mse plays emotion categories; this {kind} is not used",
                        self.doc.span(child),
                    )
                )
            else:
                what = {"info": "metadata", "reference": "a link to related media"}.get(kind, "not EmotionML")
                self.warnings.append(Diagnostic("W520", f"<{kind}> ({what}) is not used", self.doc.span(child)))
        if not categories:
            self.warnings.append(
                Diagnostic("W526", "<emotion> without a <category>: nothing names an emotion to play", span)
            )
            return None
        strength = [1.0 if value is None else value for _, value, _ in categories]
        ranked = sorted(range(len(categories)), key=lambda i: (-strength[i], i))
        name, value, where = categories[ranked[0]]
        for other in ranked[1:]:
            self.warnings.append(
                Diagnostic(
                    "W525",
                    f"<category name={categories[other][0]!r}>: one emotion at a time, "
                    f"so the strongest category ({name!r}) is played",
                    categories[other][2],
                )
            )
        if intensity is not None and value is not None:
            self.warnings.append(
                Diagnostic(
                    "W521",
                    f"<category name={name!r}>: value is not used (the intensity dimension gives the intensity)",
                    where,
                )
            )
        label = f"<emotion> {name!r}"
        timing = self.timing(emotion, label)
        if timing is None:
            return None
        if timing.end is not None and timing.end <= timing.start:
            self.errors.append(
                Diagnostic("E152", f"{label} ends at {timing.end} ms, not after its start {timing.start} ms", span)
            )
            return None
        vocabulary = self.vocabulary_of(emotion, "category") or ""
        emotion_name = resolve_emotion(self.names, vocabulary, name, where, self.known, self.warnings)
        if emotion_name is None:
            return None
        level = intensity if intensity is not None else (value if value is not None else 1.0)
        interval = EmotionInterval(emotion_name, level, 0.0, None, span, label)
        return timing, interval

    def read(self) -> InputReading:
        root = self.doc.root
        if localname(root) != "emotionml" or etree.QName(root).namespace != NAMESPACE:
            raise MseError(
                [
                    Diagnostic(
                        "E150",
                        f"the root element of an EmotionML document must be <emotionml> in {NAMESPACE}, not {root.tag}",
                        self.doc.span(root),
                    )
                ]
            )
        for node in root:
            if isinstance(node.tag, str) and localname(node) == "vocabulary":
                names = {item.get("name") or "" for item in node if isinstance(item.tag, str)}
                self.local[node.get("id") or ""] = (node.get("type") or "", names)
        timed: list[tuple[Timing, EmotionInterval]] = []
        for node in root:
            if not isinstance(node.tag, str):
                continue
            kind = localname(node)
            if kind == "emotion":
                found = self.emotion(node)
                if found is not None:
                    timed.append(found)
            elif kind != "vocabulary":
                what = "metadata" if kind == "info" else "not EmotionML"
                self.warnings.append(Diagnostic("W520", f"<{kind}> ({what}) is not used", self.doc.span(node)))
        if self.errors:
            raise MseError(self.errors)
        bases = {timing.base for timing, _ in timed}
        if len(bases) > 1:
            listed = ", ".join("clock time" if b is None else f"offsets from {b!r}" for b in sorted(bases, key=str))
            where = timed[-1][1].span
            raise MseError(
                [
                    Diagnostic(
                        "E151",
                        f"emotions on different time bases ({listed}): mse cannot lay them on one dialogue",
                        where,
                    )
                ]
            )
        origin = min((timing.start for timing, _ in timed), default=0) if None in bases else 0
        if origin:
            self.warnings.append(
                Diagnostic(
                    "W524", f"clock times: the dialogue starts at the earliest start ({origin} ms)", self.doc.span(root)
                )
            )
        intervals = [
            EmotionInterval(
                iv.emotion,
                iv.intensity,
                (timing.start - origin) / 1000,
                None if timing.end is None else (timing.end - origin) / 1000,
                iv.span,
                iv.label,
            )
            for timing, iv in timed
        ]
        events = sequence_emotions(intervals, self.warnings)
        return finish(FORMAT, events, self.warnings, self.doc.span(root))


def read_emotionml(
    source: str | Path | XmlDocument,
    *,
    names: EmotionNames | None = None,
    known: Callable[[str, Span], bool] = known_emotion,
) -> InputReading:
    """Dialogue events of an EmotionML document, and what mse does not use of it."""
    doc = source if isinstance(source, XmlDocument) else load_xml(source, what="EmotionML file")
    return _Reader(doc, names or load_emotion_names(), known).read()


def vocabulary_names(names: EmotionNames) -> Mapping[str, set[str]]:
    """The category vocabularies the name table knows, with their names (tests compare them
    with the W3C vocabulary file)."""
    return {uri: set(table) for uri, table in names.tables.items() if uri.startswith("http")}

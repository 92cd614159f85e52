"""What the FML-APML and EmotionML readers share: events with their source, emotion intervals
laid on one line, emotion names through the mapping table, and positions in an XML file.

An input becomes the events of a dialogue script (docs/dialogue.md): plain JSON objects
(``{"t", "emotion", "intensity", "until"}``, ``{"t", "say", "words", "stress"}``,
``{"t", "end": true}``), in time order, each with the ``file:line:col`` it comes from.  What the
input holds that mse cannot use is a warning with a code per kind (docs/dialogue-inputs.md),
never dropped without a word.
"""

from __future__ import annotations

import difflib
import math
import tomllib
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from lxml import etree

from mse.diagnostics import Diagnostic, MseError, Span
from mse.input_files import read_input
from mse.resources import bundled_names
from mse.syntax.safexml import XmlDocument, parse_xml

#: The mapping table shipped with mse (emotion names of each input vocabulary -> set names).
EMOTION_NAMES = Path(__file__).resolve().parent / "emotion_names.toml"
#: Section of the table for EmotionML dimension vocabularies that carry the intensity.
INTENSITY_SECTION = "intensity-dimensions"


@dataclass(frozen=True, slots=True)
class InputEvent:
    """One dialogue-script event (a JSON object) and where the input said it."""

    event: Mapping[str, Any]
    span: Span

    @property
    def t(self) -> float:
        return float(self.event["t"])


@dataclass(frozen=True, slots=True)
class InputReading:
    """A whole input read: its events in time order and what mse could not use of it."""

    format: str
    events: tuple[InputEvent, ...]
    warnings: tuple[Diagnostic, ...]


# -- emotion names -----------------------------------------------------------------------------
@dataclass(frozen=True)
class EmotionNames:
    """The mapping table: ``tables[vocabulary][name] -> set name`` ("" = no set)."""

    tables: Mapping[str, Mapping[str, str]]
    sources: tuple[str, ...] = (str(EMOTION_NAMES),)

    def table(self, vocabulary: str) -> Mapping[str, str] | None:
        return self.tables.get(vocabulary)

    def lookup(self, vocabulary: str, name: str) -> str | None:
        """The set name for ``name`` ("" when mse has none), or None when the table does not list it."""
        table = self.tables.get(vocabulary, {})
        if name in table:
            return table[name]
        folded = {key.casefold(): value for key, value in table.items()}
        return folded.get(name.casefold())

    def intensity_dimension(self, vocabulary: str) -> str | None:
        return self.tables.get(INTENSITY_SECTION, {}).get(vocabulary)


def _read_table(path: Path) -> dict[str, dict[str, str]]:
    where = Span(str(path), 1, 1)
    try:
        raw = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as error:
        raise MseError(
            [Diagnostic("E100", f"cannot read emotion name table: {error.strerror or error}", where)]
        ) from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as error:
        raise MseError([Diagnostic("E214", f"emotion name table is not valid TOML: {error}", where)]) from None
    except RecursionError:
        raise MseError([Diagnostic("E214", "emotion name table nests too deeply", where)]) from None
    tables: dict[str, dict[str, str]] = {}
    for section, entries in raw.items():
        if not isinstance(entries, dict) or not all(isinstance(v, str) for v in entries.values()):
            message = f'[{section}] must be a table of name = "set name" (strings)'
            raise MseError([Diagnostic("E214", message, where)])
        tables[section] = {str(k): str(v) for k, v in entries.items()}
    return tables


def load_emotion_names(overrides: Iterable[Path] = ()) -> EmotionNames:
    """The shipped table, then each user file over it (table by table, name by name)."""
    tables = _read_table(EMOTION_NAMES)
    sources = [str(EMOTION_NAMES)]
    for path in overrides:
        for section, entries in _read_table(Path(path)).items():
            tables.setdefault(section, {}).update(entries)
        sources.append(str(path))
    return EmotionNames(tables, tuple(sources))


def known_emotion(name: str, span: Span) -> bool:
    """What a dialogue script accepts (:func:`mse.dialogue.script.resolve_emotion`): a bundled
    behaviour set, or a set file (a relative path is looked up beside the input first)."""
    from mse.dialogue.script import resolve_emotion as resolve_in_script

    try:
        resolve_in_script(name, span)
    except MseError:
        return False
    return True


def resolve_emotion(
    names: EmotionNames,
    vocabulary: str,
    name: str,
    span: Span,
    known: Callable[[str, Span], bool],
    warnings: list[Diagnostic],
) -> str | None:
    """The set mse plays for ``name`` of ``vocabulary``, or None (reported as W522)."""
    mapped = names.lookup(vocabulary, name)
    target = name if mapped is None else mapped
    if mapped == "":
        warnings.append(
            Diagnostic(
                "W522",
                f"emotion {name!r} ({vocabulary}): mse has no behaviour set for it "
                "(the name table maps it to none); nothing is played for it",
                span,
            )
        )
        return None
    if not known(target, span):
        guess = difflib.get_close_matches(target, bundled_names(), n=1)
        hint = f"; did you mean {guess[0]!r}?" if guess else ""
        via = "" if mapped is None else f" (mapped to {target!r})"
        warnings.append(
            Diagnostic(
                "W522",
                f"emotion {name!r}{via} is not a bundled behaviour set nor a set file{hint}; "
                "map it in an emotion name table (docs/dialogue-inputs.md); nothing is played "
                "for it",
                span,
            )
        )
        return None
    return target


# -- emotions on one line ------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class EmotionInterval:
    """An emotion the input places in time: ``stop`` None when the input gives no end."""

    emotion: str
    intensity: float
    start: float
    stop: float | None
    span: Span
    label: str  # how the input names it, for messages


def sequence_emotions(intervals: Sequence[EmotionInterval], warnings: list[Diagnostic]) -> list[InputEvent]:
    """One emotion at a time, as a dialogue has: where intervals overlap, the one that started
    last holds the face (the earlier one is cut there, W523, and takes over again when the later
    one ends, if it still lasts).  An interval without an end lasts until the next one starts."""
    if not intervals:
        return []
    ordered = sorted(enumerate(intervals), key=lambda item: (item[1].start, item[0]))
    cuts: set[int] = set()
    ends = [(iv.stop if iv.stop is not None else math.inf) for iv in intervals]
    # Open intervals end where the next interval starts.
    for position, (index, interval) in enumerate(ordered):
        if interval.stop is None:
            later = [other.start for _, other in ordered[position + 1 :] if other.start > interval.start]
            ends[index] = later[0] if later else math.inf
    bounds = sorted({iv.start for iv in intervals} | {e for e in ends if math.isfinite(e)})
    segments: list[tuple[int, float, float]] = []
    for left, right in zip(bounds, [*bounds[1:], math.inf], strict=True):
        active = [i for i, iv in ordered if iv.start <= left and ends[i] > left]
        if not active:
            continue
        holder = active[-1]
        for other in active[:-1]:
            if other not in cuts:
                cuts.add(other)
                iv, over = intervals[other], intervals[holder]
                warnings.append(
                    Diagnostic(
                        "W523",
                        f"{iv.label} overlaps {over.label}: one emotion at a time, so it is "
                        f"cut at {left:g} s (the later one holds the face)",
                        iv.span,
                    )
                )
        if segments and segments[-1][0] == holder and segments[-1][2] == left:
            segments[-1] = (holder, segments[-1][1], right)
        else:
            segments.append((holder, left, right))
    events = []
    for holder, left, right in segments:
        iv = intervals[holder]
        event: dict[str, Any] = {"t": round(left, 6), "emotion": iv.emotion, "intensity": iv.intensity}
        # Announced: its own end, or the start of the emotion that cuts it.  An emotion without
        # an end is interrupted by the next one (no "until").
        if math.isfinite(right) and not (iv.stop is None and right == ends[holder]):
            event["until"] = round(right, 6)
        events.append(InputEvent(event, iv.span))
    return events


def finish(fmt: str, events: list[InputEvent], warnings: list[Diagnostic], span: Span) -> InputReading:
    """Events in time order (emotion, then speech, at the same time) and a closing ``end``."""
    emotions = [e for e in events if "emotion" in e.event]
    if not emotions:
        warnings.append(Diagnostic("W528", "the input holds no emotion mse can play", span))
    else:
        # A dialogue starts with an emotion (which face speaks?): speech before the first one is
        # spoken with it, and that is said.
        first = min(emotions, key=lambda e: e.t)
        earliest = min(e.t for e in events)
        if earliest < first.t:
            message = (
                f"the agent speaks from {earliest:g} s but the first emotion starts at {first.t:g} s: "
                f"that emotion is played from {earliest:g} s"
            )
            warnings.append(Diagnostic("W524", message, first.span))
            events = [InputEvent({**e.event, "t": earliest}, e.span) if e is first else e for e in events]
    times = [e.t for e in events]
    times += [float(e.event["until"]) for e in events if "until" in e.event]
    times += [float(w[2]) for e in events for w in e.event.get("words", ())]
    order = {"emotion": 0, "say": 1}
    ordered = sorted(events, key=lambda e: (e.t, min(order.get(k, 2) for k in e.event)))
    last = max((e for e in ordered if "emotion" in e.event), key=lambda e: e.t, default=None)
    open_ended = last is not None and "until" not in last.event and max(times) <= last.t
    if ordered and not open_ended:
        # The end of the last utterance or announced emotion.  An input whose last emotion has
        # no end and nothing after it gets no end: the planner gives that episode its horizon.
        ordered.append(InputEvent({"t": round(max(times), 6), "end": True}, span))
    return InputReading(fmt, tuple(ordered), tuple(sorted(warnings, key=Diagnostic.sort_key)))


# -- XML with positions ----------------------------------------------------------------------------
def load_xml(path: str | Path, what: str) -> XmlDocument:
    """Parse ``path`` safely (no DTD, entities or network: mse.syntax.safexml); MseError when it cannot."""
    name = str(path)
    data = read_input(path, what=what)
    root, source, problems = parse_xml(data, name)
    if root is None:
        raise MseError(problems)
    return XmlDocument(name, root, source)


def localname(element: etree._Element) -> str:
    return etree.QName(element).localname if isinstance(element.tag, str) else ""

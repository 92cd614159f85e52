"""Timelines: the contract every solver, checker and exporter shares (``mse-timeline/1``).

```json
{"format": "mse-timeline/1", "expression": "embarrassment", "duration": 10.0,
 "solver": "greedy", "seed": 7,
 "signals": [{"id": "gaze_down", "modality": "gaze", "lexeme": "gaze=look_down",
              "start": 0.0, "stop": 1.234}]}
```
Signals are sorted by start, then id; times are seconds with at most 3 decimals.
A signal entry may carry ``"motion": {...}`` (motion leaves); unknown top-level keys are
kept in ``extra`` so that tools can add data without breaking readers.  ``mse.sample``
records where the expression came from in ``"source"``: ``{"bundled": "embarrassment",
"sha256": ...}`` or ``{"path": "/abs/x.xml", "sha256": ...}`` (hash of the file's bytes);
it is optional, so older timelines and other tools' timelines still read.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any, TypeGuard

from mse.diagnostics import Diagnostic, MseError, Span
from mse.envelope import Envelope
from mse.ir.schedule import Occurrence, Schedule, to_seconds, to_ticks
from mse.limits import (
    MAX_NAME_CHARS,
    MAX_PATH_CHARS,
    MAX_SECONDS,
    MIN_DURATION_SECONDS,
    time_problem,
    xml_char_problem,
)

FORMAT = "mse-timeline/1"
_KNOWN_KEYS = {"format", "expression", "duration", "solver", "seed", "signals"}


@dataclass(frozen=True, slots=True)
class TimelineSignal:
    """One occurrence of a signal, in seconds."""

    id: str
    modality: str
    lexeme: str
    start: float
    stop: float
    motion: Mapping[str, Any] | None = None
    #: In a dialogue (docs/dialogue.md): the episode's index, the envelope (intensity, attack,
    #: sustain, release), the planned stop when an unannounced change cut the occurrence, and
    #: whether it carries over the previous episode's occurrence of the same lexeme.
    episode: int | None = None
    envelope: Envelope | None = None
    planned_stop: float | None = None
    carry: bool = False

    @property
    def cut(self) -> bool:
        return self.planned_stop is not None

    def shifted(self, offset: float) -> TimelineSignal:
        planned = None if self.planned_stop is None else round(self.planned_stop + offset, 3)
        start, stop = round(self.start + offset, 3), round(self.stop + offset, 3)
        return replace(self, start=start, stop=stop, planned_stop=planned)

    def to_json(self) -> dict[str, Any]:
        entry: dict[str, Any] = {
            "id": self.id,
            "modality": self.modality,
            "lexeme": self.lexeme,
            "start": round(self.start, 3),
            "stop": round(self.stop, 3),
        }
        if self.motion is not None:
            entry["motion"] = dict(self.motion)
        if self.episode is not None:
            entry["episode"] = self.episode
        if self.envelope is not None:
            entry.update(self.envelope.to_json())
        if self.planned_stop is not None:
            entry["cut"] = True
            entry["planned_stop"] = round(self.planned_stop, 3)
        if self.carry:
            entry["carry"] = True
        return entry


@dataclass(frozen=True, slots=True)
class Timeline:
    """A solved timeline with its provenance."""

    expression: str
    duration: float
    signals: tuple[TimelineSignal, ...]
    solver: str = "greedy"
    seed: int | None = None
    extra: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        ordered = tuple(sorted(self.signals, key=lambda s: (round(s.start, 3), s.id, s.stop)))
        object.__setattr__(self, "signals", ordered)

    @property
    def source(self) -> Mapping[str, str] | None:
        """Where the expression came from (``"source"`` in the JSON), or None when unrecorded."""
        value = self.extra.get("source")
        if not isinstance(value, Mapping):
            return None
        return {str(k): str(v) for k, v in value.items() if isinstance(v, str)}

    # -- conversions -------------------------------------------------------------------
    def to_schedule(self) -> Schedule:
        return Schedule.of(
            to_ticks(self.duration),
            (Occurrence(to_ticks(s.start), to_ticks(s.stop), s.id) for s in self.signals),
        )

    def with_signals(self, signals: Iterable[TimelineSignal]) -> Timeline:
        return replace(self, signals=tuple(signals))

    # -- dialogues (docs/dialogue.md) --------------------------------------------------
    @property
    def episodes(self) -> list[dict[str, Any]]:
        """The episodes of a dialogue timeline (``"episodes"`` in the JSON); [] for one expression."""
        value = self.extra.get("episodes")
        return [dict(e) for e in value if isinstance(e, Mapping)] if isinstance(value, list) else []

    @property
    def utterances(self) -> list[dict[str, Any]]:
        value = self.extra.get("utterances")
        return [dict(u) for u in value if isinstance(u, Mapping)] if isinstance(value, list) else []

    def as_episodes(self) -> Timeline:
        """A dialogue timeline: this timeline as one announced episode when it has none."""
        if self.episodes:
            return self
        episode: dict[str, Any] = {
            "index": 0, "emotion": self.expression, "start": 0.0, "stop": round(self.duration, 3),
            "announced": True, "interrupted": False, "intensity": 1.0,
        }
        if self.source is not None:
            episode["source"] = dict(self.source)
        signals = [replace(s, episode=0) for s in self.signals]
        utterances = list(self.utterances)  # what was said during it (speech anchors read it)
        extra = {**self.extra, "episodes": [episode], "utterances": utterances}
        return replace(self, signals=tuple(signals), extra=extra)

    def shift(self, offset: float) -> Timeline:
        """This timeline ``offset`` seconds later (a dialogue's episodes and utterances too);
        the duration grows by ``offset``, so it still starts at 0."""
        if offset < 0:
            raise ValueError("a timeline can only be shifted later (offset >= 0)")
        dialogue = self.as_episodes()
        episodes = [{**e, **_moved(e, offset, ("start", "stop", "plan_stop"))} for e in dialogue.episodes]
        for episode in episodes:
            if isinstance(episode.get("dropped"), list):
                episode["dropped"] = [{**d, **_moved(d, offset, ("start", "stop"))} for d in episode["dropped"]]
        utterances = []
        for utterance in dialogue.utterances:
            moved = {**utterance, **_moved(utterance, offset, ("start", "stop"))}
            if isinstance(utterance.get("words"), list):
                moved["words"] = [[w[0], round(w[1] + offset, 3), round(w[2] + offset, 3)] for w in utterance["words"]]
            utterances.append(moved)
        return replace(
            dialogue,
            duration=round(self.duration + offset, 3),
            signals=tuple(s.shifted(offset) for s in dialogue.signals),
            extra={**dialogue.extra, "episodes": episodes, "utterances": utterances},
        )

    def then(self, other: Timeline) -> Timeline:
        """This timeline followed by ``other`` (shifted to start at this one's end): one dialogue
        whose episodes are this one's and then ``other``'s, renumbered; each stays checkable."""
        first = self.as_episodes()
        second = other.as_episodes().shift(self.duration)
        count = len(first.episodes)
        renumbered = [{**e, "index": int(e.get("index", 0)) + count} for e in second.episodes]
        signals = [*first.signals, *(replace(s, episode=(s.episode or 0) + count) for s in second.signals)]
        names = [str(e.get("emotion", "")) for e in (*first.episodes, *renumbered)]
        return replace(
            first,
            expression="dialogue" if len(set(names)) > 1 else first.expression,
            duration=second.duration,
            signals=tuple(signals),
            seed=first.seed,
            extra={**first.extra, "episodes": [*first.episodes, *renumbered],
                   "utterances": [*first.utterances, *second.utterances]},
        )

    def to_json(self) -> dict[str, Any]:
        obj: dict[str, Any] = {
            "format": FORMAT,
            "expression": self.expression,
            "duration": round(self.duration, 3),
            "solver": self.solver,
            "seed": self.seed,
            "signals": [s.to_json() for s in self.signals],
        }
        for key, value in self.extra.items():
            if key not in obj:
                obj[key] = value
        return obj

    def dumps(self, *, indent: int | None = 2) -> str:
        return json.dumps(self.to_json(), indent=indent, ensure_ascii=False)

    @staticmethod
    def from_json(obj: Any, *, path: str = "<timeline>", index: int | None = None, label: str = "") -> Timeline:
        """Build a timeline from decoded JSON; raises MseError (E212) when it is malformed."""
        # JSON lines: the entry's line; otherwise the document's start, the message naming
        # the field (decoded JSON keeps no positions).
        where = Span(path, (index + 1) if index is not None else 1, 1)

        def fail(message: str) -> MseError:
            return MseError([Diagnostic("E212", f"{label}{message}", where)])

        if not isinstance(obj, dict):
            raise fail("a timeline must be a JSON object")
        if "signals" not in obj and {"id", "start", "stop"} <= obj.keys():
            raise fail(
                "this is a signal line of 'mse sample --stream', not a timeline: timelines come from "
                "'mse sample' without --stream (--format json or jsonl)"
            )
        fmt = obj.get("format", FORMAT)
        if fmt != FORMAT:
            raise fail(f"unsupported timeline format {fmt!r} (expected {FORMAT!r})")
        duration = obj.get("duration")
        if not _is_number(duration) or not MIN_DURATION_SECONDS <= float(duration) <= MAX_SECONDS:
            raise fail(f"'duration' must be a number of seconds in [{MIN_DURATION_SECONDS:g}, {MAX_SECONDS:g}]")
        raw_signals = obj.get("signals", [])
        if not isinstance(raw_signals, list):
            raise fail("'signals' must be a list")
        signals: list[TimelineSignal] = []
        for position, entry in enumerate(raw_signals):
            if not isinstance(entry, dict):
                raise fail(f"signals[{position}] must be an object")
            sid, start, stop = entry.get("id"), entry.get("start"), entry.get("stop")
            if not isinstance(sid, str) or not _is_number(start) or not _is_number(stop):
                raise fail(f"signals[{position}] needs a string 'id' and numeric 'start' and 'stop'")
            for key, time in (("start", start), ("stop", stop)):
                problem = time_problem(float(time))
                if problem is not None:
                    raise fail(f"signals[{position}].{key} {problem}")
            for key in ("id", "modality", "lexeme"):
                problem = _name_problem(str(entry.get(key, "")))
                if problem is not None:
                    raise fail(f"signals[{position}].{key} {problem}")
            motion = entry.get("motion")
            if isinstance(motion, dict) and isinstance(motion.get("file"), str):
                problem = _name_problem(motion["file"], MAX_PATH_CHARS)
                if problem is not None:
                    raise fail(f"signals[{position}].motion.file {problem}")
            signals.append(
                TimelineSignal(
                    id=sid,
                    modality=str(entry.get("modality", "")),
                    lexeme=str(entry.get("lexeme", sid)),
                    start=float(start),
                    stop=float(stop),
                    motion=dict(motion) if isinstance(motion, dict) else None,
                    **_dialogue_fields(entry, position, fail),
                )
            )
        for key in ("expression", "solver"):
            problem = _name_problem(str(obj.get(key, "")))
            if problem is not None:
                raise fail(f"'{key}' {problem}")
        seed = obj.get("seed")
        return Timeline(
            expression=str(obj.get("expression", "")),
            duration=float(duration),
            signals=tuple(signals),
            solver=str(obj.get("solver", "unknown")),
            seed=seed if isinstance(seed, int) and not isinstance(seed, bool) else None,
            extra={k: v for k, v in obj.items() if k not in _KNOWN_KEYS},
        )


def _name_problem(text: str, limit: int = MAX_NAME_CHARS) -> str | None:
    """Why ``text`` cannot be a name of a timeline (too long, or characters XML cannot hold)."""
    if len(text) > limit:
        return f"is {len(text)} characters long; at most {limit}"
    return xml_char_problem(text)


def _dialogue_fields(entry: Mapping[str, Any], position: int, fail: Any) -> dict[str, Any]:
    """The optional dialogue keys of a signal entry (docs/dialogue.md)."""
    fields: dict[str, Any] = {}
    episode = entry.get("episode")
    if episode is not None:
        if not isinstance(episode, int) or isinstance(episode, bool) or episode < 0:
            raise fail(f"signals[{position}].episode must be an episode index (an integer >= 0)")
        fields["episode"] = episode
    phases = [entry.get(key) for key in ("intensity", "attack", "sustain", "release")]
    if any(value is not None for value in phases):
        if not all(_is_number(value) and value >= 0 for value in phases):
            raise fail(f"signals[{position}] needs 'intensity', 'attack', 'sustain' and 'release' (numbers >= 0) "
                       "together")
        fields["envelope"] = Envelope(*(float(value) for value in phases if _is_number(value)))
    planned = entry.get("planned_stop")
    if planned is not None:
        if not _is_number(planned) or time_problem(float(planned)) is not None:
            raise fail(f"signals[{position}].planned_stop must be a time in seconds")
        fields["planned_stop"] = float(planned)
    if entry.get("carry") is True:
        fields["carry"] = True
    return fields


def _is_number(value: object) -> TypeGuard[int | float]:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def from_schedule(
    schedule: Schedule,
    *,
    expression: str,
    signal_info: Mapping[str, tuple[str, str]],
    solver: str,
    seed: int | None,
    motions: Mapping[str, Mapping[str, Any]] | None = None,
) -> Timeline:
    """Wrap a solver's schedule; ``signal_info`` maps id -> (modality, lexeme)."""
    motions = motions or {}
    signals = tuple(
        TimelineSignal(
            id=o.signal,
            modality=signal_info[o.signal][0],
            lexeme=signal_info[o.signal][1],
            start=to_seconds(o.start),
            stop=to_seconds(o.stop),
            motion=motions.get(o.signal),
        )
        for o in schedule.occurrences
    )
    return Timeline(expression, to_seconds(schedule.duration), signals, solver, seed)


def concatenate(timelines: Iterable[Timeline]) -> Timeline:
    """The timelines one after the other as one dialogue (see :meth:`Timeline.then`)."""
    result: Timeline | None = None
    for timeline in timelines:
        result = timeline.as_episodes() if result is None else result.then(timeline)
    if result is None:
        raise ValueError("concatenate needs at least one timeline")
    return result


def _moved(entry: Mapping[str, Any], offset: float, keys: tuple[str, ...]) -> dict[str, float]:
    return {key: round(float(entry[key]) + offset, 3) for key in keys if _is_number(entry.get(key))}


#: What each signal line of ``mse sample --stream`` adds to the signal: its timeline's key.
_STREAM_KEYS = ("expression", "seed", "duration")


def _stream_key(obj: Any) -> tuple[object, ...] | None:
    """The timeline a ``--stream`` signal line belongs to, or None for any other object."""
    if not isinstance(obj, dict) or "signals" in obj or not {"id", "start", "stop", *_STREAM_KEYS} <= obj.keys():
        return None
    return tuple(json.dumps(obj[key]) for key in _STREAM_KEYS)


def _assembled(lines: list[tuple[int, Any]], path: str) -> Timeline:
    """One timeline from consecutive ``--stream`` signal lines of the same timeline."""
    first = lines[0][1]
    signals = [{k: v for k, v in obj.items() if k not in _STREAM_KEYS} for _, obj in lines]
    document = {"format": FORMAT, **{key: first[key] for key in _STREAM_KEYS}, "signals": signals}
    return Timeline.from_json(document, path=path, index=lines[0][0], label="streamed timeline: ")


def loads_many(text: str, *, path: str = "<timeline>") -> list[Timeline]:
    """Read one timeline, a JSON array of them, or JSON lines (lines end at "\n" only:
    U+2028 or U+0085 inside a string are not line ends).  The signal lines of
    ``mse sample --stream`` are assembled: consecutive lines of one expression, seed and
    duration make one timeline."""
    from mse.input_files import parse_json

    if not text.strip():
        raise MseError([Diagnostic("E212", "no timeline in the input", Span(path, 1, 1))])
    try:
        decoded = parse_json(text, path, code="E212")
    except MseError as whole_error:
        lines = text.split("\n")
        if sum(1 for line in lines if line.strip()) < 2:
            raise whole_error from None
        timelines: list[Timeline] = []
        streamed: list[tuple[int, Any]] = []
        for number, line in enumerate(lines):
            if not line.strip():
                continue
            try:
                decoded_line = parse_json(line, path, code="E212", line=number + 1)
            except MseError:
                if not timelines and not streamed:  # one document over several lines: its own error
                    raise whole_error from None
                raise
            key = _stream_key(decoded_line)
            if streamed and key != _stream_key(streamed[0][1]):
                timelines.append(_assembled(streamed, path))
                streamed = []
            if key is not None:
                streamed.append((number, decoded_line))
            else:
                timelines.append(Timeline.from_json(decoded_line, path=path, index=number))
        if streamed:
            timelines.append(_assembled(streamed, path))
        return timelines
    if _stream_key(decoded) is not None:  # a stream of one signal
        return [_assembled([(0, decoded)], path)]
    if isinstance(decoded, list):
        return [Timeline.from_json(item, path=path, label=f"timeline [{n}]: ") for n, item in enumerate(decoded)]
    return [Timeline.from_json(decoded, path=path)]


def dumps_jsonl(timelines: Iterable[Timeline]) -> str:
    return "".join(t.dumps(indent=None) + "\n" for t in timelines)

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
from mse.ir.schedule import Occurrence, Schedule, to_seconds, to_ticks
from mse.limits import MAX_SECONDS, MIN_DURATION_SECONDS, time_problem, xml_char_problem

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
                problem = xml_char_problem(str(entry.get(key, "")))
                if problem is not None:
                    raise fail(f"signals[{position}].{key} {problem}")
            motion = entry.get("motion")
            if isinstance(motion, dict) and isinstance(motion.get("file"), str):
                problem = xml_char_problem(motion["file"])
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
                )
            )
        for key in ("expression", "solver"):
            problem = xml_char_problem(str(obj.get(key, "")))
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


def loads_many(text: str, *, path: str = "<timeline>") -> list[Timeline]:
    """Read one timeline, a JSON array of them, or JSON lines (lines end at "\n" only:
    U+2028 or U+0085 inside a string are not line ends)."""
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
        for number, line in enumerate(lines):
            if not line.strip():
                continue
            try:
                decoded_line = parse_json(line, path, code="E212", line=number + 1)
            except MseError:
                if not timelines:  # one document over several lines: its own error is the one
                    raise whole_error from None
                raise
            timelines.append(Timeline.from_json(decoded_line, path=path, index=number))
        return timelines
    if isinstance(decoded, list):
        return [Timeline.from_json(item, path=path, label=f"timeline [{n}]: ") for n, item in enumerate(decoded)]
    return [Timeline.from_json(decoded, path=path)]


def dumps_jsonl(timelines: Iterable[Timeline]) -> str:
    return "".join(t.dumps(indent=None) + "\n" for t in timelines)

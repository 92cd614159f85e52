"""The ``mse serve`` protocol, version :data:`PROTOCOL` (docs/serve.md; JSON Schema in
``protocol.schema.json`` next to this module), independent of the network.

A client sends JSON objects: the dialogue script's events (``{"t": 0, "emotion": "anger"}``,
``{"say": "..."}``, ``{"end": true}``, :mod:`mse.dialogue.script`) and typed requests
(``{"type": "hello", ...}`` options before the first event, ``{"type": "timeline"}``).  The
server answers each message with the occurrences it commits (``occurrence``, pushed one by one as
the planner commits them), the episodes it closes (``episode``), a BML block per new episode when
asked (``bml``), then ``ack`` with the message's number; or with one ``error`` (the session goes on).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mse.diagnostics import MseError, Span
from mse.dialogue.script import EmotionEvent, EndEvent, SayEvent, parse_event
from mse.dialogue.session import Session
from mse.timeline import Timeline, TimelineSignal

PROTOCOL = 1
SCHEMA = Path(__file__).with_name("protocol.schema.json")
CLOCKS = ("real", "script")
HELLO_KEYS = frozenset({"type", "protocol", "seed", "clock", "bml", "keep"})


class ProtocolError(Exception):
    """A message the session cannot take: answered with ``{"type": "error", code, message}``."""

    def __init__(self, code: str, message: str) -> None:
        super().__init__(message)
        self.code = code
        self.message = message


def error_message(code: str, message: str, seq: int | None = None) -> dict[str, Any]:
    out: dict[str, Any] = {"type": "error", "code": code, "message": message}
    if seq is not None:
        out["seq"] = seq
    return out


@dataclass(frozen=True, slots=True)
class Options:
    """A session's options (the ``hello`` message): planner seed, clock, BML blocks, whole timeline."""

    seed: int = 0
    clock: str = "real"
    bml: bool = False
    keep: bool = False


def _hello(obj: dict[str, Any], default: Options) -> Options:
    for key in obj:
        if key not in HELLO_KEYS:
            allowed = ", ".join(sorted(HELLO_KEYS))
            raise ProtocolError("bad-message", f"unknown key {key!r} in hello; allowed: {allowed}")
    protocol = obj.get("protocol", PROTOCOL)
    if protocol != PROTOCOL or isinstance(protocol, bool):
        raise ProtocolError("protocol", f"protocol {protocol!r} is not supported: this server speaks {PROTOCOL}")
    seed = obj.get("seed", default.seed)
    if not isinstance(seed, int) or isinstance(seed, bool) or not 0 <= seed < 2**31:
        raise ProtocolError("bad-message", f"'seed' must be an integer in [0, 2^31), not {seed!r}")
    clock = obj.get("clock", default.clock)
    if clock not in CLOCKS:
        raise ProtocolError("bad-message", f"'clock' must be one of {', '.join(CLOCKS)}, not {clock!r}")
    flags = {}
    for key in ("bml", "keep"):
        value = obj.get(key, getattr(default, key))
        if not isinstance(value, bool):
            raise ProtocolError("bad-message", f"{key!r} must be true or false, not {value!r}")
        flags[key] = value
    return Options(seed, clock, flags["bml"], flags["keep"])


class Connection:
    """One client's session: :meth:`handle` turns a message's text into the messages out.

    ``now`` is the wall clock (seconds, monotonic); with the real clock the session's time 0 is
    its first event, and an event without ``t`` happens now."""

    def __init__(self, name: str, default: Options, now: Callable[[], float]) -> None:
        self.name = name
        self.options = default
        self._now = now
        self._origin: float | None = None
        self._session: Session | None = None
        self._seq = 0
        self._last_t = 0.0
        self._ended = False
        self._episodes_sent = 0
        self._blocks_sent: set[int] = set()
        self._stalled = False
        #: Messages that changed the dialogue (the face track is rebuilt when it grows).
        self._changes = 0
        self._track: tuple[int, Any, Any] | None = None

    @property
    def session(self) -> Session:
        if self._session is None:
            self._session = Session(seed=self.options.seed, keep=self.options.keep)
        return self._session

    def clock(self) -> float:
        """The session's time now (real clock; 0 before the first event)."""
        if self._origin is None:
            return 0.0
        return round(self._now() - self._origin, 3)

    def handle(self, text: str | bytes) -> Iterator[dict[str, Any]]:
        """The messages out for one message in, each as soon as it is known."""
        self._seq += 1
        seq = self._seq
        try:
            if isinstance(text, bytes):
                raise ProtocolError("bad-message", "binary messages are not accepted: send JSON text")
            try:
                obj = json.loads(text, parse_constant=_no_constant)
            except (ValueError, RecursionError) as error:
                raise ProtocolError("bad-json", f"not JSON: {error}") from None
            if not isinstance(obj, dict):
                raise ProtocolError("bad-message", "a message is a JSON object such as {\"emotion\": \"joy\"}")
            kind = obj.get("type")
            if kind is None:
                yield from self._event(obj, seq)
            elif kind == "hello":
                if self._session is not None:
                    raise ProtocolError("state", "hello comes before the first event")
                self.options = _hello(obj, self.options)
                yield {"type": "hello", "protocol": PROTOCOL, "session": self.name, "seed": self.options.seed,
                       "clock": self.options.clock, "bml": self.options.bml, "keep": self.options.keep}
            elif kind == "timeline":
                yield self._timeline()
            elif kind == "face":
                yield self._face(obj)
            elif kind == "tracks":
                yield self._tracks(obj)
            elif kind == "clock":
                yield {"type": "clock", "t": self.clock() if self.options.clock == "real" else self._last_t}
            else:
                raise ProtocolError("unknown-type", f"unknown message type {kind!r}: hello, timeline, face, tracks, "
                                    "clock, or an event without 'type'")
        except ProtocolError as problem:
            yield error_message(problem.code, problem.message, seq)
            return
        except MseError as failure:
            diagnostic = failure.diagnostics[0] if failure.diagnostics else None
            yield error_message("event", diagnostic.message if diagnostic else str(failure), seq)
            return
        yield {"type": "ack", "seq": seq}

    # -- events ----------------------------------------------------------------------------
    def _event(self, obj: dict[str, Any], seq: int) -> Iterator[dict[str, Any]]:
        if self._ended:
            raise ProtocolError("state", "the dialogue has ended: open a new connection for a new one")
        obj = dict(obj)
        if self.options.clock == "real":
            if self._origin is None:
                self._origin = self._now()
            if "t" not in obj:
                obj["t"] = max(self.clock(), self._last_t)
        elif "t" not in obj:
            raise ProtocolError("event", "on the script clock every event has its time 't'")
        t = obj.get("t")
        if isinstance(t, int | float) and not isinstance(t, bool) and math.isfinite(t) and t < self._last_t:
            raise ProtocolError("past", f"t = {t:g} s is before the session's last event at {self._last_t:g} s: "
                                "events come in time order")
        event = parse_event(obj, Span(f"<{self.name}>", seq, 1))
        if isinstance(event, SayEvent) and self._session is None:
            raise ProtocolError("state", "an utterance before the first emotion (which face speaks?)")
        if isinstance(event, EndEvent) and self._session is None:
            raise ProtocolError("state", "the dialogue has not started (start with an emotion)")
        session = self.session
        self._stalled = False
        self._changes += 1
        for signal in session.stream(event):
            yield _occurrence(signal)
        self._last_t = event.t
        yield from self._closed_episodes(session)
        if isinstance(event, EndEvent):
            self._ended = True
        elif self.options.bml and isinstance(event, EmotionEvent | SayEvent):
            block = self._block(session, interrupted=isinstance(event, EmotionEvent))
            if block is not None:
                yield block

    def tick(self, lead: float) -> list[dict[str, Any]]:
        """On the real clock: an episode that runs on past its plan (no event came) is continued
        ``lead`` seconds before its plan ends; the messages that brings (none on the script clock)."""
        session = self._session
        if self.options.clock != "real" or session is None or self._ended or self._stalled:
            return []
        try:
            out = [_occurrence(signal) for signal in session.advance(self.clock() + lead)]
        except MseError as failure:
            self._stalled = True  # not tried again before the next event
            message = failure.diagnostics[0].message if failure.diagnostics else str(failure)
            return [error_message("event", message)]
        if out:
            self._changes += 1
            out.extend(self._closed_episodes(session))
            block = self._block(session, interrupted=False) if self.options.bml else None
            if block is not None:
                out.append(block)
        return out

    def _closed_episodes(self, session: Session) -> Iterator[dict[str, Any]]:
        closed = session.closed_episodes
        while self._episodes_sent < len(closed):
            yield {"type": "episode", **closed[self._episodes_sent]}
            self._episodes_sent += 1

    def _block(self, session: Session, *, interrupted: bool) -> dict[str, Any] | None:
        """The running episode as one BML block (its id unique in the session, REPLACE when it
        interrupts the episode before, MERGE when it continues one)."""
        from mse.export import render
        from mse.export.options import ExportOptions

        running = session.running_plan()
        if running is None:
            return None
        entry, signals, utterances = running
        index = int(entry["index"])
        if index in self._blocks_sent:
            return None
        self._blocks_sent.add(index)
        origin = min([float(entry["start"]), *(s.start for s in signals)])
        stop = max([float(entry["stop"]), *(s.stop for s in signals)])
        block = Timeline(str(entry["emotion"]), round(stop - origin, 3), tuple(s.shifted(-origin) for s in signals),
                         "greedy", session.seed, {"utterances": [_shifted(u, origin) for u in utterances]})
        identifier = f"bml_{self.name}_{index}"
        composition = "REPLACE" if interrupted and index > 0 and not entry.get("continues") else "MERGE"
        text = render(block, "bml", ExportOptions(block_id=identifier, composition=composition))
        return {"type": "bml", "id": identifier, "episode": index, "offset": round(origin, 3),
                "composition": composition, "bml": text}

    def _face(self, obj: dict[str, Any]) -> dict[str, Any]:
        """The face player's picture (SVG) at ``t`` (default: now), drawn from the dialogue so far
        (the live page shows it; needs ``keep``)."""
        from mse.export.face.page import face_svg, face_track
        from mse.export.options import ExportOptions
        from mse.export.xmltext import render

        if set(obj) - {"type", "t"}:
            raise ProtocolError("bad-message", "a face request has 'type' and 't' only")
        t = obj.get("t", self.clock() if self.options.clock == "real" else self._last_t)
        if not isinstance(t, int | float) or isinstance(t, bool) or not math.isfinite(t) or t < 0:
            raise ProtocolError("bad-message", f"'t' must be a number of seconds, not {t!r}")
        timeline = self._timeline_object()
        if self._track is None or self._track[0] != self._changes:
            from mse.export.face.rig import default_rig

            rig = default_rig()
            self._track = (self._changes, rig, face_track(timeline, ExportOptions(), rig))
        _, rig, track = self._track
        return {"type": "face", "t": round(float(t), 3), "svg": render(face_svg(rig, track, float(t)))}

    def _tracks(self, obj: dict[str, Any]) -> dict[str, Any]:
        """The dialogue so far as curves an avatar or robot plays (docs/tracks.md): ARKit
        blendshapes (``arkit-json``, the default; ``arkit`` CSV) or OpenFace 2.0 action units
        (``openface``), as text (needs ``keep``)."""
        from mse.export import render

        if set(obj) - {"type", "format"}:
            raise ProtocolError("bad-message", "a tracks request has 'type' and 'format' only")
        fmt = obj.get("format", "arkit-json")
        if fmt not in TRACK_FORMATS:
            raise ProtocolError("bad-message", f"'format' is one of {', '.join(TRACK_FORMATS)}, not {fmt!r}")
        return {"type": "tracks", "format": fmt, "data": render(self._timeline_object(), fmt)}

    def _timeline_object(self) -> Timeline:
        if self._session is None:
            raise ProtocolError("state", "the dialogue has no episode yet (start with an emotion)")
        if not self.options.keep:
            raise ProtocolError("state", "the session keeps no timeline: say {\"type\": \"hello\", \"keep\": true} "
                                "before the first event")
        return self._session.timeline()

    def _timeline(self) -> dict[str, Any]:
        return {"type": "timeline", "timeline": self._timeline_object().to_json()}


#: The track formats a session hands out as text (``vrma`` is binary: ``mse export``).
TRACK_FORMATS = ("arkit-json", "arkit", "openface")


def _no_constant(name: str) -> Any:
    raise ValueError(f"{name} is not a JSON number")


def _shifted(utterance: dict[str, Any], offset: float) -> dict[str, Any]:
    moved = dict(utterance)
    moved["start"] = round(float(utterance["start"]) - offset, 3)
    moved["stop"] = round(float(utterance["stop"]) - offset, 3)
    moved["words"] = [[w[0], round(w[1] - offset, 3), round(w[2] - offset, 3)] for w in utterance.get("words", [])]
    return moved


def _occurrence(signal: TimelineSignal) -> dict[str, Any]:
    return {"type": "occurrence", **signal.to_json()}


__all__ = ["CLOCKS", "PROTOCOL", "SCHEMA", "Connection", "Options", "ProtocolError", "error_message"]

"""A dialogue session: emotion changes and utterances arrive in time order; each emotion change
is planned at once into an episode and its occurrences are handed out (docs/dialogue.md).

Planning is incremental: an event at ``t`` changes nothing before ``t`` (occurrences that started
before it keep their start, and their stop when it came before ``t``); an episode is planned
alone, for its announced length or, without one, a :data:`HORIZON` at a time, so the cost of an
event does not grow with the dialogue's length.  What an interruption does to the running
episode (cut, release, drop) is :mod:`mse.ir.evaluate.episodes`' definition, and the envelope of
every occurrence is :mod:`mse.envelope`'s.

>>> from mse.dialogue import Session
>>> session = Session(seed=3)
>>> first = session.emotion(0.0, "anger", intensity=0.8, until=3.7)
>>> all(s.episode == 0 and 0.0 <= s.start < 3.7 for s in first)
True
>>> _ = session.say(0.4, "I can't believe you did that", stress=["believe"])
>>> _ = session.emotion(3.7, "relief")
>>> _ = session.end(8.7)
>>> timeline = session.timeline()
>>> [(e["emotion"], e["start"], e["stop"], e["interrupted"]) for e in timeline.episodes]
[('anger', 0.0, 3.7, False), ('relief', 3.7, 8.7, True)]
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from mse.diagnostics import Diagnostic, MseError, Span
from mse.dialogue.script import (
    CODE,
    EmotionEvent,
    EndEvent,
    Event,
    SayEvent,
    Word,
    check_sequence,
    estimate_words,
    parse_event,
    resolve_emotion,
)
from mse.envelope import CUT_RELEASE, Envelope, cut_envelope, envelope
from mse.ir.anchors import Speech, episode_model, uses_anchors
from mse.ir.anchors import Word as SpokenWord
from mse.ir.model import Model
from mse.ir.schedule import to_seconds
from mse.timeline import Timeline, TimelineSignal

#: Seconds planned at once for an episode whose end is not announced; when it runs longer, the
#: same emotion continues with a new horizon (a further episode marked ``"continues": true``).
HORIZON = 10.0
_EPSILON = 1e-9


def _r(value: float) -> float:
    return round(value, 3)


@dataclass
class _Running:
    """The episode being played: its plan, absolute times."""

    index: int
    emotion: str
    model: Model
    source: dict[str, str] | None
    start: float
    plan_stop: float
    announced: bool
    intensity: float
    planned: list[TimelineSignal]
    continues: bool = False
    #: The rest of the plan, as the sampler commits it (None: all of it is in ``planned``).
    pending: Iterator[TimelineSignal] | None = None
    #: For a set with speech anchors: the utterances (indices) its plan read.
    said: tuple[int, ...] | None = None

    def pull(self) -> TimelineSignal | None:
        """The plan's next occurrence (appended to ``planned``), or None when it is complete."""
        if self.pending is None:
            return None
        signal = next(self.pending, None)
        if signal is None:
            self.pending = None
        else:
            self.planned.append(signal)
        return signal

    def pull_through(self, limit: float) -> None:
        """Pull the plan up to the first occurrence that starts after ``limit``."""
        while self.pending is not None and (not self.planned or self.planned[-1].start <= limit):
            if self.pull() is None:
                break

    def drain(self) -> list[TimelineSignal]:
        while self.pull() is not None:
            pass
        return self.planned


@dataclass
class _Loaded:
    model: Model
    source: dict[str, str] | None
    own_intensity: dict[str, float] = field(default_factory=dict)


class Session:
    """A dialogue planned as it goes; see the module docstring.

    ``seed`` makes the session reproducible (episode *i* is planned with seed ``seed + i``);
    ``base`` is the folder relative set files are looked up in first; ``keep=False`` forgets
    committed occurrences once handed out (a server that streams them needs no timeline)."""

    def __init__(self, *, seed: int = 0, horizon: float = HORIZON, base: str | os.PathLike[str] | None = None,
                 keep: bool = True) -> None:
        if not horizon > 0:
            raise ValueError("horizon must be positive")
        self.seed = seed
        self.horizon = horizon
        self.keep = keep
        self._base = Path(base) if base is not None else None
        self._models: dict[str, _Loaded] = {}
        self._running: _Running | None = None
        self._episodes: list[dict[str, Any]] = []
        self._signals: list[TimelineSignal] = []
        self._utterances: list[dict[str, Any]] = []
        self._speeches: list[Speech] = []
        self._first: Event | None = None
        self._last: Event | None = None
        self._last_say: SayEvent | None = None
        self._clock = 0.0
        self._ended: float | None = None
        self._next_index = 0
        from mse.solve.protocol import get_solver

        get_solver("greedy")  # import the sampler now, not at the first event

    # -- events -------------------------------------------------------------------------------
    def feed(self, event: Event) -> list[TimelineSignal]:
        """Apply one event (checked against the ones before); the occurrences it commits: the
        previous episode's that it closes and, for an emotion, the new episode's whole plan."""
        return list(self.stream(event))

    def stream(self, event: Event) -> Iterator[TimelineSignal]:
        """As :meth:`feed`, the occurrences handed out as soon as each is committed: the new
        episode's first one comes before its whole plan is made.  The event is checked and
        applied at once (before the first ``next``); leaving the iterator unfinished is fine:
        the rest of the plan is made when it is needed."""
        # The order rules of a whole script, against the first event, the last utterance and
        # the last event alone (what the order of the whole script needs).
        before: list[Event] = []
        for known in (self._first, self._last_say, self._last):
            if known is not None and all(known is not e for e in before):
                before.append(known)
        check_sequence([*before, event])
        if isinstance(event, EmotionEvent):
            steps: Iterator[TimelineSignal] = self._emotion(event)
        elif isinstance(event, SayEvent):
            steps = self._say(event)
            self._last_say = event
        else:
            steps = iter(self._end(event))
        self._first = self._first or event
        self._last = event
        return steps

    def emotion(
        self, t: float, emotion: str, intensity: float = 1.0, until: float | None = None
    ) -> list[TimelineSignal]:
        """From ``t`` express ``emotion``: the planned occurrences of the new episode (and of the
        previous one, cut at ``t`` when it is interrupted), each with its episode and envelope."""
        obj: dict[str, Any] = {"t": t, "emotion": emotion, "intensity": intensity}
        if until is not None:
            obj["until"] = until
        return self.feed(parse_event(obj, self._span()))

    def say(self, t: float, text: str, words: Sequence[tuple[str, float, float]] | None = None,
            stress: Iterable[str] = ()) -> SayEvent:
        """An utterance from ``t`` (word timings estimated from the text when not given)."""
        obj: dict[str, Any] = {"t": t, "say": text, "stress": list(stress)}
        if words is not None:
            obj["words"] = [list(w) for w in words]
        event = parse_event(obj, self._span())
        self.feed(event)
        assert isinstance(event, SayEvent)
        return event

    def end(self, t: float) -> list[TimelineSignal]:
        """The dialogue ends at ``t``: the running episode is cut there (or continued up to it)."""
        return self.feed(parse_event({"t": t, "end": True}, self._span()))

    def _span(self) -> Span:
        return Span(str(self._base / "<session>") if self._base else "<session>")

    # -- planning -----------------------------------------------------------------------------
    def load(self, emotion: str) -> Model:
        """Load ``emotion``'s set now (a server does it before the dialogue: the first event
        of an emotion then pays no loading); E217 with did-you-mean when it is unknown."""
        return self._load(emotion, self._span()).model

    def _load(self, name: str, span: Span) -> _Loaded:
        loaded = self._models.get(name)
        if loaded is None:
            from mse.api import load
            from mse.sampling import expression_source

            path = resolve_emotion(name, span)
            model = load(path)
            own = {s.id: s.intensity for s in model.signals}
            loaded = self._models[name] = _Loaded(model, expression_source(model), own)
        return loaded

    def _plan(self, loaded: _Loaded, index: int, start: float, length: float, intensity: float,
              span: Span, said: Sequence[int]) -> Iterator[TimelineSignal]:
        """One episode's occurrences, as the sampler's stream commits them: a timeline of
        ``length`` seconds (the default solver: the walk, its complete fallback), at ``start``."""
        from mse.solve.protocol import GreedyOptions, NoSolution, SolveRequest, get_solver

        # Speech anchors read what the agent has said by the episode's start (_open).
        model = episode_model(loaded.model, [self._speeches[i] for i in said], start, start + length)
        # A length planned once (an announced episode), or a model resolved against one
        # utterance, is not worth the sampler's plan cache.
        once = abs(length - self.horizon) > _EPSILON or model is not loaded.model
        # The walk's stream, without the rejection stage: its latency, and no pilot per episode.
        request = SolveRequest(duration=length, seed=self.seed + index, greedy=GreedyOptions(cache_plan=not once),
                               rejection=False)
        try:
            for occurrence in get_solver("greedy").stream(model, request):
                modality, lexeme = model.signal_info[occurrence.signal]
                begin = _r(start + to_seconds(occurrence.start))
                finish = _r(start + to_seconds(occurrence.stop))
                strength = intensity * loaded.own_intensity.get(occurrence.signal, 1.0)
                leaf = model.signal(occurrence.signal).motion
                yield TimelineSignal(occurrence.signal, modality, lexeme, begin, finish,
                                     {"action": leaf.action} if leaf is not None else None, episode=index,
                                     envelope=envelope(modality, begin, finish, strength))
        except NoSolution as failure:
            reason = failure.diagnostics[0].message if failure.diagnostics else "no solution"
            message = f"no timeline of {model.name!r} fits an episode of {length:g} s ({reason})"
            raise MseError([Diagnostic(CODE, message, span)]) from None

    def _open(self, loaded: _Loaded, emotion: str, start: float, stop: float, announced: bool, intensity: float,
              span: Span, continues: bool = False) -> _Running:
        index = self._next_index
        self._next_index += 1
        said: tuple[int, ...] = ()
        if uses_anchors(loaded.model):  # what has been said by now that reaches into the episode
            said = tuple(i for i, u in enumerate(self._speeches) if u.start <= start + _EPSILON and u.stop > start)
        plan = self._plan(loaded, index, start, stop - start, intensity, span, said)
        running = _Running(index, emotion, loaded.model, loaded.source, start, stop, announced, intensity, [],
                           continues, plan)
        running.said = said if uses_anchors(loaded.model) else None
        return running

    def _advance(self, t: float, span: Span, *, final: bool = False) -> list[TimelineSignal]:
        """Play the running episode up to ``t``: continue it by horizons while its plan ends
        before ``t``; end it as planned at ``t``, or cut it there.  The occurrences it closes."""
        running = self._running
        closed: list[TimelineSignal] = []
        while running is not None and running.plan_stop < t - _EPSILON:
            closed.extend(self._close(running, running.plan_stop))
            loaded = self._models[running.emotion]
            start = running.plan_stop
            running = self._open(loaded, running.emotion, start, _r(start + self.horizon), False,
                                 running.intensity, span, continues=True)
            self._carry(closed, running, start)
        if running is not None:
            closed.extend(self._close(running, t, final=final))
        self._running = None
        return closed

    def advance(self, t: float) -> list[TimelineSignal]:
        """Continue the running episode by horizons while its plan ends before ``t`` (a live
        session on the wall clock calls it ahead of time, with no event); the occurrences it
        commits: the closed part's last versions, then each continuation's plan."""
        running = self._running
        handed: list[TimelineSignal] = []
        if self._ended is not None:
            return handed
        while running is not None and running.plan_stop < t - _EPSILON:
            closed = self._close(running, running.plan_stop)
            start = running.plan_stop
            running = self._open(self._models[running.emotion], running.emotion, start, _r(start + self.horizon),
                                 False, running.intensity, self._span(), continues=True)
            self._carry(closed, running, start)
            self._commit(closed)
            self._running = running
            handed.extend(closed)
            handed.extend(running.drain())
        return handed

    def _close(self, running: _Running, t: float, *, final: bool = False) -> list[TimelineSignal]:
        """The running episode ends at ``t``: as planned, or interrupted (cut and dropped).
        At the dialogue's end (``final``) nothing follows, so cut occurrences stop at ``t``."""
        interrupted = t < running.plan_stop - _EPSILON
        running.drain()
        kept: list[TimelineSignal] = []
        dropped: list[dict[str, Any]] = []
        for signal in running.planned:
            if signal.start >= t - _EPSILON:
                dropped.append({"id": signal.id, "start": signal.start, "stop": signal.stop})
            elif signal.stop <= t + _EPSILON:
                kept.append(signal)
            else:
                strength = signal.envelope.intensity if signal.envelope else 1.0
                stop, shape = cut_envelope(signal.modality, signal.start, signal.stop, t, strength, final=final)
                kept.append(replace(signal, stop=_r(stop), envelope=shape, planned_stop=signal.stop))
        entry: dict[str, Any] = {
            "index": running.index,
            "emotion": running.emotion,
            "source": running.source,
            "start": _r(running.start),
            "stop": _r(t),
            "announced": running.announced,
            "interrupted": interrupted,
            "intensity": running.intensity,
            "plan_stop": _r(running.plan_stop),
        }
        if running.continues:
            entry["continues"] = True
        if running.said is not None:
            entry["speech"] = list(running.said)
        if dropped:
            entry["dropped"] = dropped
        self._episodes.append(entry)
        return kept

    @staticmethod
    def _carry(closed: list[TimelineSignal], running: _Running, t: float) -> None:
        """A lexeme both neighbouring episodes show carries over: the previous occurrence holds
        (no release) up to the new one's start, which rises from there without attack."""
        running.pull_through(t + CUT_RELEASE)
        reaching = {s.lexeme: i for i, s in enumerate(closed) if s.stop >= t - _EPSILON and s.start < t}
        for position, signal in enumerate(running.planned):
            if signal.start > t + CUT_RELEASE + _EPSILON or signal.lexeme not in reaching:
                continue
            i = reaching.pop(signal.lexeme)
            before = closed[i]
            if signal.start > before.stop + _EPSILON:
                continue
            shape = before.envelope or Envelope(1.0, 0.0, before.stop - before.start, 0.0)
            attack = min(shape.attack, signal.start - before.start)
            held = replace(shape, attack=attack, sustain=max(0.0, signal.start - before.start - attack), release=0.0)
            closed[i] = replace(before, stop=_r(max(signal.start, t)), envelope=held)
            if signal.envelope is not None:
                rise = signal.envelope
                running.planned[position] = replace(
                    signal, carry=True, envelope=replace(rise, attack=0.0, sustain=rise.sustain + rise.attack))

    def _commit(self, signals: list[TimelineSignal]) -> None:
        if self.keep:
            self._signals.extend(signals)

    def _emotion(self, event: EmotionEvent) -> Iterator[TimelineSignal]:
        loaded = self._load(event.emotion, event.span)
        closed = self._advance(event.t, event.span)
        stop = event.until if event.until is not None else _r(event.t + self.horizon)
        running = self._open(loaded, event.emotion, event.t, stop, event.until is not None, event.intensity,
                             event.span)
        self._running = running
        self._clock = event.t
        self._carry(closed, running, running.start)
        self._commit(closed)
        return self._hand_out(closed, running)

    @staticmethod
    def _hand_out(closed: list[TimelineSignal], running: _Running) -> Iterator[TimelineSignal]:
        """The closed occurrences, then the new plan as it is committed."""
        yield from closed
        handed = 0
        while True:
            while handed < len(running.planned):
                handed += 1
                yield running.planned[handed - 1]
            if running.pull() is None:
                return

    def _say(self, event: SayEvent) -> Iterator[TimelineSignal]:
        """Record the utterance; when the running episode's set refers to the agent's speech
        and the utterance falls within its plan, the rest of the episode is planned again from
        the utterance's start, with it (what is committed before it stays as it is)."""
        running = self._running
        if running is None:
            raise MseError([Diagnostic(CODE, "an utterance before the first emotion (which face speaks?)", event.span)])
        stressed = {word.start for word in event.stressed_words()}
        self._speeches.append(Speech(event.t, event.stop, tuple(
            SpokenWord(w.text, w.start, w.stop, w.start in stressed) for w in event.words)))
        self._utterances.append({
            "index": len(self._utterances),
            "start": event.t,
            "stop": event.stop,
            "text": event.text,
            "words": [[w.text, w.start, w.stop] for w in event.words],
            "stress": list(event.stress),
        })
        if not uses_anchors(running.model) or event.t >= running.plan_stop - _EPSILON:
            return iter(())
        until = running.plan_stop if running.announced else None
        closed = self._advance(event.t, event.span)
        loaded = self._models[running.emotion]
        stop = until if until is not None else _r(event.t + self.horizon)
        again = self._open(loaded, running.emotion, event.t, stop, until is not None, running.intensity,
                           event.span, continues=True)
        self._running = again
        self._carry(closed, again, event.t)
        self._commit(closed)
        return self._hand_out(closed, again)

    def _end(self, event: EndEvent) -> list[TimelineSignal]:
        closed = self._advance(event.t, event.span, final=True)
        self._commit(closed)
        self._ended = event.t
        return closed

    # -- results --------------------------------------------------------------------------------
    @property
    def current_episode(self) -> int | None:
        """The index of the episode being played (None before the first emotion, after the end)."""
        return self._running.index if self._running is not None else None

    @property
    def closed_episodes(self) -> Sequence[dict[str, Any]]:
        """The episodes closed so far, in order (the timeline's ``episodes`` entries)."""
        return self._episodes

    def running_plan(self) -> tuple[dict[str, Any], list[TimelineSignal], list[dict[str, Any]]] | None:
        """The episode being played (its entry as planned, its whole plan, the utterances that
        start in it), for a realizer sent one block per episode (``mse serve``); None when none."""
        running = self._running
        if running is None:
            return None
        utterances = [u for u in self._utterances if running.start <= u["start"] < running.plan_stop]
        return self._running_entry(running), list(running.drain()), utterances

    @staticmethod
    def _running_entry(running: _Running) -> dict[str, Any]:
        return {
            "index": running.index, "emotion": running.emotion, "source": running.source,
            "start": _r(running.start), "stop": _r(running.plan_stop), "announced": running.announced,
            "interrupted": False, "intensity": running.intensity, "plan_stop": _r(running.plan_stop),
            **({"continues": True} if running.continues else {}),
        }

    @property
    def utterance_words(self) -> list[tuple[Word, ...]]:
        return [tuple(Word(w[0], w[1], w[2]) for w in u["words"]) for u in self._utterances]

    def timeline(self) -> Timeline:
        """The dialogue so far as one multi-episode timeline (a running episode as planned)."""
        signals = list(self._signals)
        episodes = list(self._episodes)
        duration = self._ended
        if self._running is not None:
            running = self._running
            signals.extend(running.drain())
            episodes.append(self._running_entry(running))
            duration = running.plan_stop
        if duration is None or not episodes:
            raise MseError([Diagnostic(CODE, "the dialogue has no episode yet (start with an emotion)",
                                       Span("<session>"))])
        names = {str(e["emotion"]) for e in episodes}
        expression = next(iter(names)) if len(names) == 1 else "dialogue"
        for episode in episodes:
            if episode.get("source") is None:
                episode.pop("source", None)
        return Timeline(expression, _r(duration), tuple(signals), "greedy", self.seed,
                        {"episodes": episodes, "utterances": list(self._utterances)})


def plan_script(events: Sequence[Event], *, seed: int = 0, horizon: float = HORIZON,
                base: str | os.PathLike[str] | None = None) -> Timeline:
    """The whole timeline of a script's events (``mse live``)."""
    session = Session(seed=seed, horizon=horizon, base=base)
    for event in events:
        session.feed(event)
    return session.timeline()


__all__ = ["HORIZON", "Session", "estimate_words", "plan_script"]

"""``mse check`` of a dialogue: its timeline's episodes, each against its own behaviour set, by
the evaluator's one definition (:mod:`mse.ir.evaluate.episodes`)."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

from mse.diagnostics import Diagnostic, MseError, Span
from mse.ir.anchors import Speech, episode_model, utterances_from_json
from mse.ir.evaluate.episodes import Episode, EpisodeViolation, check_episodes
from mse.ir.model import Model
from mse.ir.schedule import Occurrence, to_ticks
from mse.timeline import Timeline


def _number(entry: Mapping[str, Any], key: str, label: str) -> float:
    value = entry.get(key)
    if not isinstance(value, int | float) or isinstance(value, bool):
        raise MseError([Diagnostic("E212", f"{label}: '{key}' must be a number of seconds", Span("<timeline>"))])
    return float(value)


def model_loader() -> Callable[[Mapping[str, Any]], Model]:
    """Loads each episode's set once: its recorded source (bundled name or path), else its emotion."""
    from mse.api import load

    cache: dict[str, Model] = {}

    def model_of(episode: Mapping[str, Any]) -> Model:
        source = episode.get("source")
        name = str(episode.get("emotion", ""))
        if isinstance(source, Mapping):
            name = str(source.get("path") or source.get("bundled") or name)
        if name not in cache:
            cache[name] = load(name)
        return cache[name]

    return model_of


def episodes_of(timeline: Timeline, model_of: Callable[[Mapping[str, Any]], Model]) -> list[Episode]:
    """The timeline's episodes as the evaluator sees them (ticks, absolute)."""
    by_index: dict[int, list[Any]] = {}
    for signal in timeline.signals:
        by_index.setdefault(signal.episode if signal.episode is not None else -1, []).append(signal)
    if -1 in by_index:
        stray = by_index[-1][0]
        message = f"signal {stray.id} at {stray.start:g} s belongs to no episode (it has no 'episode')"
        raise MseError([Diagnostic("E212", message, Span("<timeline>"))])
    result = []
    known = set()
    utterances = utterances_from_json(timeline.extra.get("utterances", []), Span("<timeline>"))
    for entry in timeline.episodes:
        index = entry.get("index")
        label = f"episode {index}"
        if not isinstance(index, int) or isinstance(index, bool) or index in known:
            raise MseError([Diagnostic("E212", f"{label}: 'index' must be a new integer", Span("<timeline>"))])
        known.add(index)
        start, stop = _number(entry, "start", label), _number(entry, "stop", label)
        plan_stop = _number(entry, "plan_stop", label) if "plan_stop" in entry else stop
        played, cut = [], []
        for signal in by_index.pop(index, []):
            occurrence = Occurrence(to_ticks(signal.start), to_ticks(signal.stop), signal.id)
            if signal.planned_stop is not None:
                cut.append((occurrence, to_ticks(signal.planned_stop)))
            else:
                played.append(occurrence)
        dropped = []
        for item in entry.get("dropped", []) if isinstance(entry.get("dropped"), list) else []:
            if isinstance(item, Mapping):
                begin, end = _number(item, "start", label), _number(item, "stop", label)
                dropped.append(Occurrence(to_ticks(begin), to_ticks(end), str(item.get("id", ""))))
        result.append(Episode(
            index=index,
            emotion=str(entry.get("emotion", "")),
            # speech anchors read the utterances overlapping the plan, in the episode's own time
            model=episode_model(model_of(entry), _planned_with(entry, utterances), start, plan_stop),
            start=to_ticks(start),
            stop=to_ticks(stop),
            plan_stop=to_ticks(plan_stop),
            played=tuple(played),
            cut=tuple(cut),
            dropped=tuple(dropped),
            interrupted=bool(entry.get("interrupted", False)),
        ))
    if by_index:
        index = min(by_index)
        message = f"signals of episode {index} but no such episode in 'episodes'"
        raise MseError([Diagnostic("E212", message, Span("<timeline>"))])
    return result


def _planned_with(entry: Mapping[str, Any], utterances: Sequence[Speech]) -> Sequence[Speech]:
    """The utterances an episode's anchors read: those its ``speech`` names (a live session
    records what had been said when it planned the episode), else every one."""
    named = entry.get("speech")
    if not isinstance(named, list):
        return utterances
    return [utterances[i] for i in named if isinstance(i, int) and not isinstance(i, bool) and 0 <= i < len(utterances)]


def check_dialogue(timeline: Timeline, model_of: Callable[[Mapping[str, Any]], Model] | None = None,
                   ) -> list[EpisodeViolation]:
    """Every violation of a multi-episode timeline, episode by episode (empty: consistent)."""
    episodes = episodes_of(timeline, model_of or model_loader())
    return check_episodes(episodes, to_ticks(timeline.duration))

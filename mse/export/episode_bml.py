"""A dialogue as one BML block per episode, for a realizer fed as the dialogue goes (``mse serve``).

``render(timeline, "bml")`` writes a whole dialogue as one block.  A live agent instead sends a
block when an episode starts: :func:`episode_blocks` gives, per episode, a block whose id is the
dialogue's with the episode's number (``bml_<dialogue>_<n>``, unique per episode and per dialogue),
whose times count from the block's ``offset`` in the dialogue (send it then: BML times are
relative to a block's start, and a MERGE block starts on arrival), with the episode's occurrences
and the utterances that start in it, their behaviours tied to the words (:mod:`mse.export.speech_bml`).
A behaviour cannot refer to speech in another block (BML 1.0 has no reference across blocks), so
one that lies on a word of an utterance started in an earlier episode keeps a numeric time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

from mse.export.behaviours import block_id
from mse.export.options import ExportOptions
from mse.timeline import Timeline


@dataclass(frozen=True, slots=True)
class EpisodeBlock:
    """One episode's block: its number (from 1), ``<bml id>``, start in the dialogue, text."""

    number: int
    id: str
    offset: float
    text: str


def _shifted_utterance(utterance: dict[str, Any], offset: float) -> dict[str, Any]:
    moved = dict(utterance)
    for key in ("start", "stop"):
        if isinstance(moved.get(key), int | float):
            moved[key] = round(float(moved[key]) - offset, 6)
    moved["words"] = [[w[0], round(w[1] - offset, 6), round(w[2] - offset, 6)] for w in utterance.get("words", [])]
    return moved


def episode_blocks(timeline: Timeline, fmt: str = "bml", options: ExportOptions | None = None) -> list[EpisodeBlock]:
    """The dialogue's blocks, one per episode, in ``fmt`` (``bml`` or ``greta-bml``)."""
    from mse.export import render

    options = options or ExportOptions()
    dialogue = timeline.as_episodes()
    base = block_id(dialogue, options)
    episodes = dialogue.episodes
    blocks = []
    for position, episode in enumerate(episodes):
        index = int(episode.get("index", position))
        start = float(episode.get("start", 0.0))
        following = float(episodes[position + 1].get("start", math.inf)) if position + 1 < len(episodes) else math.inf
        signals = [s for s in dialogue.signals if (s.episode if s.episode is not None else 0) == index]
        utterances = [u for u in dialogue.utterances if start <= float(u.get("start", 0.0)) < following]
        origin = min([start, *(s.start for s in signals), *(float(u.get("start", start)) for u in utterances)])
        end = max(
            [
                float(episode.get("stop", start)),
                *(s.stop for s in signals),
                *(float(u.get("stop", start)) for u in utterances),
            ]
        )
        block = Timeline(
            dialogue.expression,
            round(end - origin, 6),
            tuple(s.shifted(-origin) for s in signals),
            dialogue.solver,
            dialogue.seed,
            extra={"utterances": [_shifted_utterance(u, origin) for u in utterances]},
        )
        number = position + 1
        identifier = f"{base}_{number}"
        text = render(block, fmt, replace(options, block_id=identifier))
        blocks.append(EpisodeBlock(number, identifier, round(origin, 6), text))
    return blocks

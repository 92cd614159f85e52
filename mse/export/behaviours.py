"""What every BML writer shares: occurrences planned as behaviours, block ids, provenance."""

from __future__ import annotations

from dataclasses import dataclass

from mse.export.lexemes import Lexeme, format_seconds, modality_of, sanitize_id, split_lexeme, unique_ids
from mse.export.options import COMPOSITIONS, ExportOptions
from mse.timeline import Timeline, TimelineSignal


@dataclass(frozen=True, slots=True)
class Behaviour:
    """One occurrence ready to be written: its unique id, lexeme and export modality."""

    id: str
    signal: TimelineSignal
    lexeme: Lexeme
    modality: str

    @property
    def start(self) -> str:
        return format_seconds(self.signal.start)

    @property
    def end(self) -> str:
        return format_seconds(self.signal.stop)


def plan_behaviours(timeline: Timeline) -> list[Behaviour]:
    """The timeline's occurrences with BML-safe unique ids, in time order."""
    ids = unique_ids(s.id for s in timeline.signals)
    return [
        Behaviour(bid, s, lexeme, modality_of(s.modality, lexeme))
        for bid, s in zip(ids, timeline.signals, strict=True)
        for lexeme in (split_lexeme(s.lexeme),)
    ]


def block_id(timeline: Timeline, options: ExportOptions | None = None) -> str:
    """The ``<bml id>``: an xs:ID (no leading digit) that is never the reserved ``bml``.

    ``options.block_id`` when given (``--bml-id``); a dialogue's carries its seed and length
    (``bml_dialogue_s7_8700ms``), so that dialogues sent one after another do not collide."""
    if options is not None and options.block_id:
        chosen = sanitize_id(options.block_id, prefix="")
        return chosen if chosen != "bml" else "bml_"
    if timeline.episodes:
        seed = "x" if timeline.seed is None else str(timeline.seed)
        stem = sanitize_id(f"{timeline.expression or 'dialogue'}_s{seed}_{round(timeline.duration * 1000)}ms",
                           prefix="")
        return "bml_" + stem
    return "bml_" + sanitize_id(timeline.expression or "timeline", prefix="")


def amount(b: Behaviour, base: float | None = None) -> str | None:
    """BML ``amount`` of a behaviour: ``base`` (1 when None) scaled by the occurrence's
    intensity (:mod:`mse.envelope`); None when neither says anything (the writer's default)."""
    intensity = b.signal.envelope.intensity if b.signal.envelope is not None else None
    if intensity is None:
        return None if base is None else format_seconds(base)
    return format_seconds(round((1.0 if base is None else base) * intensity, 3))


def composition(options: ExportOptions) -> str:
    value = options.composition.strip().upper()
    return value if value in COMPOSITIONS else "MERGE"


def timing(b: Behaviour) -> dict[str, str | float | int | None]:
    return {"id": b.id, "start": b.start, "end": b.end}


def provenance(timeline: Timeline) -> str:
    """``embarrassment — 10 s — solver greedy — seed 7``: what made this timeline."""
    seed = "none" if timeline.seed is None else str(timeline.seed)
    return (
        f"{timeline.expression or 'timeline'} — {format_seconds(timeline.duration)} s — "
        f"solver {timeline.solver} — seed {seed}"
    )

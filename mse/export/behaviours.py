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


def block_id(timeline: Timeline) -> str:
    """The ``<bml id>``: an xs:ID (no leading digit) that is never the reserved ``bml``."""
    return "bml_" + sanitize_id(timeline.expression or "timeline", prefix="")


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

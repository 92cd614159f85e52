"""A corpus of annotated sequences: what every reader produces and every learner step reads.

Readers (ELAN, CSV/TSV, mse timelines) give *raw* annotations: a tier, a label, start and
stop in milliseconds and the place in the file they came from.  :func:`build_corpus` turns
them into signals: a tier becomes a modality (``--tiers face,gaze=Gaze R`` or a mapping
file), a label becomes a signal id (mapped, else made an identifier), overlapping
annotations of one signal in one sequence are merged (the semantics forbids a signal to
overlap itself) and each sequence gets its duration (given by the file, else the last stop).
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from mse.diagnostics import Diagnostic, Span
from mse.ir.model import KNOWN_MODALITIES
from mse.limits import MAX_NAME_CHARS

_NOT_IDENTIFIER = re.compile(r"[^A-Za-z0-9_]+")


@dataclass(frozen=True, slots=True)
class Annotation:
    """One annotated interval of a tier, in milliseconds."""

    tier: str
    label: str
    start: int
    stop: int
    span: Span
    lexeme: str | None = None  # mse timelines carry the signal's lexeme
    motion: str | None = None  # ... and its motion action, when it is a motion leaf
    modality: str | None = None  # a reader that knows the modality (timelines) says so


@dataclass(frozen=True, slots=True)
class RawSequence:
    """The annotations of one recording (one ELAN file, one CSV sequence, one timeline)."""

    name: str
    annotations: tuple[Annotation, ...]
    span: Span
    duration: int | None = None  # milliseconds, when the file says it


@dataclass(frozen=True)
class TierMapping:
    """Which tiers are read and what they become.

    ``tiers``: tier name -> modality (only these tiers are read when ``only_listed``);
    ``labels``: annotation value -> signal id."""

    tiers: Mapping[str, str] = field(default_factory=dict)
    labels: Mapping[str, str] = field(default_factory=dict)
    only_listed: bool = False


DEFAULT_MAPPING = TierMapping()


@dataclass(frozen=True, slots=True)
class SignalInfo:
    id: str
    modality: str
    lexeme: str
    motion: str | None = None


@dataclass(frozen=True)
class CorpusSequence:
    """One sequence: its duration and, per signal, its occurrences (start, stop) in ms, sorted."""

    name: str
    duration: int
    occurrences: Mapping[str, tuple[tuple[int, int], ...]]
    span: Span


@dataclass(frozen=True)
class Corpus:
    sequences: tuple[CorpusSequence, ...]
    signals: Mapping[str, SignalInfo]

    @property
    def typical_duration(self) -> int:
        """The median sequence duration in ms (the duration the learned set is checked at)."""
        durations = sorted(s.duration for s in self.sequences)
        return durations[len(durations) // 2] if durations else 0


def identifier(text: str) -> str:
    """A constraint-language identifier for ``text`` (``"look down"`` -> ``look_down``)."""
    cleaned = _NOT_IDENTIFIER.sub("_", text.strip()).strip("_")
    if not cleaned:
        return ""
    return cleaned if not cleaned[0].isdigit() else f"_{cleaned}"


def modality_of(tier: str, mapping: TierMapping) -> str | None:
    """The modality of ``tier``; None when the tier is not read."""
    if tier in mapping.tiers:
        return mapping.tiers[tier]
    lowered = {name.lower(): modality for name, modality in mapping.tiers.items()}
    if tier.lower() in lowered:
        return lowered[tier.lower()]
    if mapping.only_listed:
        return None
    name = identifier(tier).lower()
    return name or None


def build_corpus(
    raw: Sequence[RawSequence], mapping: TierMapping = DEFAULT_MAPPING
) -> tuple[Corpus, list[Diagnostic]]:
    """Signals and sequences from raw annotations; notes (W503) for what was merged or left out."""
    notes: list[Diagnostic] = []
    # label -> modalities it appears on: a label used on two modalities names two signals.
    resolved: list[tuple[RawSequence, list[tuple[Annotation, str, str]]]] = []
    modalities_of: dict[str, set[str]] = {}
    for sequence in raw:
        kept: list[tuple[Annotation, str, str]] = []
        for annotation in sequence.annotations:
            modality = annotation.modality or modality_of(annotation.tier, mapping)
            if modality is None:
                continue
            signal = mapping.labels.get(annotation.label) or identifier(annotation.label)
            longest = max(len(signal), len(modality))
            if longest > MAX_NAME_CHARS:
                notes.append(Diagnostic("E121", f"annotation label or tier name of {longest} characters; "
                                        f"names are at most {MAX_NAME_CHARS}", annotation.span))
                continue
            if not signal:
                notes.append(Diagnostic("W503", f"annotation {annotation.label!r} has no usable name; left out",
                                        annotation.span))
                continue
            kept.append((annotation, modality, signal))
            modalities_of.setdefault(signal, set()).add(modality)
        resolved.append((sequence, kept))
    signals: dict[str, SignalInfo] = {}
    sequences: list[CorpusSequence] = []
    for sequence, kept in resolved:
        grouped: dict[str, list[tuple[int, int, Span]]] = {}
        for annotation, modality, label_id in kept:
            signal_id = label_id if len(modalities_of[label_id]) == 1 else identifier(f"{modality}_{label_id}")
            if signal_id not in signals:
                lexeme = annotation.lexeme if annotation.lexeme is not None else annotation.label
                signals[signal_id] = SignalInfo(signal_id, modality, lexeme, annotation.motion)
            grouped.setdefault(signal_id, []).append((annotation.start, annotation.stop, annotation.span))
        occurrences = {sid: _merged(sid, spans, notes) for sid, spans in grouped.items()}
        last_stop = max((o[-1][1] for o in occurrences.values() if o), default=0)
        duration = sequence.duration if sequence.duration is not None else last_stop
        if duration <= 0:
            notes.append(Diagnostic("W503", f"sequence {sequence.name!r} has no annotation; its length is unknown, "
                                    "left out", sequence.span))
            continue
        sequences.append(CorpusSequence(sequence.name, duration, occurrences, sequence.span))
    return Corpus(tuple(sequences), dict(sorted(signals.items()))), notes


def _merged(signal: str, spans: list[tuple[int, int, Span]], notes: list[Diagnostic]) -> tuple[tuple[int, int], ...]:
    """Occurrences of one signal in start order, overlapping ones merged (with a note)."""
    merged: list[list[int]] = []
    for start, stop, span in sorted(spans, key=lambda item: (item[0], item[1])):
        if merged and start < merged[-1][1]:
            notes.append(Diagnostic("W503", f"{signal} overlaps its own previous annotation "
                                    f"(ending at {merged[-1][1] / 1000:g} s); merged", span))
            merged[-1][1] = max(merged[-1][1], stop)
        else:
            merged.append([start, stop])
    return tuple((start, stop) for start, stop in merged)


def is_known_modality(name: str) -> bool:
    return name in KNOWN_MODALITIES

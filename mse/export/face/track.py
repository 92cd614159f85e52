"""A timeline as face channels over time: one key per occurrence, with onset/apex/offset.

Each occurrence whose lexeme resolves (:mod:`mse.export.face.lexicon`) becomes a
:class:`Key`; its weight over time is an envelope (0 at start and stop, a smoothstep up
during ``attack``, 1 at the apex, a smoothstep down during ``release``; :mod:`mse.envelope`
gives the phases, or the occurrence's own envelope and intensity when it carries one), multiplied by an
oscillation (nods, shakes), by saccades (a scanning gaze: fixations held, joined by fast
jumps) or replaced by pulses (blinks).  Back-to-back occurrences of one lexeme (the next
starts within :data:`MERGE_GAP` of the previous one's end) are one key: the expression holds
instead of relaxing and tightening again between them.  Channel values are the sum of
weight x target over the keys, action units clamped to [0, 1], so overlapping expressions
blend.  ``face.js`` computes the same from :meth:`Track.to_json`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from mse.envelope import phases
from mse.export.face.actions import Action
from mse.export.face.lexicon import Resolver
from mse.export.face.rig import FloatArray, Rig
from mse.export.lexemes import modality_of, split_lexeme
from mse.timeline import Timeline, TimelineSignal

#: Occurrences of one lexeme this close (seconds) or overlapping are played as one.
MERGE_GAP = 0.1
#: Saccades: (duration as a share of the period, target as a share of the gaze) of each
#: fixation of a cycle, and the length of a jump (a saccade of 10-20 degrees takes 40-60 ms).
SACCADE_FIXATIONS: tuple[tuple[float, float], ...] = (
    (1.0, 1.0),
    (0.7, -0.55),
    (1.3, 0.25),
    (0.8, -1.0),
    (1.2, 0.6),
    (1.0, -0.2),
)
SACCADE_JUMP = 0.04


@dataclass(frozen=True)
class Key:
    """One occurrence's contribution: ``targets`` are (rig channel index, value)."""

    signal: str
    lexeme: str
    modality: str
    start: float
    stop: float
    attack: float
    release: float
    targets: tuple[tuple[int, float], ...]
    repeat: tuple[float, float] | None = None
    oscillate: tuple[float, str] | None = None

    def to_json(self) -> dict[str, Any]:
        return {
            "signal": self.signal,
            "start": self.start,
            "stop": self.stop,
            "attack": self.attack,
            "release": self.release,
            "targets": [[c, v] for c, v in self.targets],
            "repeat": list(self.repeat) if self.repeat else None,
            "oscillate": list(self.oscillate) if self.oscillate else None,
        }


@dataclass(frozen=True)
class Marker:
    """An occurrence the face cannot show: drawn as a labelled marker while it is active."""

    signal: str
    lexeme: str
    modality: str
    start: float
    stop: float

    @property
    def label(self) -> str:
        return f"{self.signal}: {self.lexeme}"


@dataclass(frozen=True)
class Track:
    keys: tuple[Key, ...]
    markers: tuple[Marker, ...]
    notes: tuple[str, ...]  # one line per unmapped lexeme or undrawable action unit
    clamped: tuple[int, ...]  # channels kept in [0, 1] (action units)
    channel_count: int
    bodies: tuple[Marker, ...] = ()  # occurrences shown by the body only (a motion file)

    def to_json(self) -> dict[str, Any]:
        return {
            "keys": [k.to_json() for k in self.keys],
            "markers": [{"label": m.label, "start": m.start, "stop": m.stop} for m in self.markers],
            "clamped": list(self.clamped),
        }

    def values(self, times: FloatArray) -> FloatArray:
        """Channel values ``[len(times), channels]``."""
        result = np.zeros((len(times), self.channel_count))
        for key in self.keys:
            weight = key_weight(key, times)
            for channel, value in key.targets:
                result[:, channel] += weight * value
        if self.clamped:
            index = list(self.clamped)
            result[:, index] = np.clip(result[:, index], 0.0, 1.0)
        return result

    def active_markers(self, time: float) -> list[Marker]:
        return [m for m in self.markers if m.start <= time < m.stop]


def arms_only(key: Key, rig: Rig) -> bool:
    """Whether the key moves only the hands (a gesture): the face view does not draw it."""
    return bool(key.targets) and all(rig.channels[channel].startswith("hand_") for channel, _ in key.targets)


def face_view_track(track: Track, rig: Rig) -> Track:
    """The track as the face view shows it: gestures it does not draw become markers."""
    import dataclasses

    gestures = [key for key in track.keys if arms_only(key, rig)]
    if not gestures:
        return track
    extra = tuple(Marker(k.signal, k.lexeme, k.modality, k.start, k.stop) for k in gestures)
    return dataclasses.replace(track, markers=track.markers + extra)


def _smooth(u: FloatArray) -> FloatArray:
    u = np.clip(u, 0.0, 1.0)
    return u * u * (3.0 - 2.0 * u)


def key_weight(key: Key, times: FloatArray) -> FloatArray:
    """The key's weight at ``times`` (see the module docstring)."""
    t = np.asarray(times, dtype=np.float64)
    inside = (t > key.start) & (t < key.stop)
    if key.stop <= key.start:
        return np.zeros_like(t)
    if key.repeat is not None:
        every, length = key.repeat
        span = key.stop - key.start
        count = max(1, round(span / every))
        slot = span / count
        width = min(length, slot)
        index = np.clip(np.floor((t - key.start) / slot), 0, count - 1)
        centre = key.start + (index + 0.5) * slot
        pulse = _smooth(1.0 - np.abs(t - centre) / (width / 2.0))
        return np.where(inside, pulse, 0.0)
    rise = _smooth((t - key.start) / key.attack) if key.attack > 0 else np.ones_like(t)
    fall = _smooth((key.stop - t) / key.release) if key.release > 0 else np.ones_like(t)
    weight = np.where(inside, np.minimum(rise, fall), 0.0)
    if key.oscillate is not None:
        period, shape = key.oscillate
        if shape == "saccade":
            return weight * saccades(t - key.start, period)
        phase = 2.0 * math.pi * (t - key.start) / period
        weight = weight * (np.sin(phase) if shape == "sine" else (1.0 - np.cos(phase)) / 2.0)
    return weight


def saccades(elapsed: FloatArray, period: float) -> FloatArray:
    """Fixations (:data:`SACCADE_FIXATIONS`, cycled) held, each reached by a jump of
    :data:`SACCADE_JUMP` seconds from the previous one (from 0 for the first)."""
    durations = np.array([share for share, _ in SACCADE_FIXATIONS]) * period
    targets = np.array([target for _, target in SACCADE_FIXATIONS])
    ends = np.cumsum(durations)
    u = np.maximum(np.asarray(elapsed, dtype=np.float64), 0.0)
    cycle = np.floor(u / ends[-1])
    rest = u - cycle * ends[-1]
    index = np.minimum(np.searchsorted(ends, rest, side="right"), len(ends) - 1)
    previous = np.where((index == 0) & (cycle == 0), 0.0, targets[index - 1])
    jump = _smooth((rest - (ends[index] - durations[index])) / SACCADE_JUMP)
    result: FloatArray = previous + (targets[index] - previous) * jump
    return result


def merge_back_to_back(keys: list[Key]) -> list[Key]:
    """One key for occurrences of one lexeme that follow each other within :data:`MERGE_GAP`
    (or overlap): the first one's onset, the last one's offset, the stronger targets."""
    order = sorted(range(len(keys)), key=lambda i: (keys[i].start, i))
    merged: dict[int, Key] = {}
    open_key: dict[tuple[str, str, object, object], int] = {}
    for i in order:
        key = keys[i]
        group = (key.lexeme, key.modality, key.repeat, key.oscillate)
        j = open_key.get(group)
        if j is not None and key.start <= merged[j].stop + MERGE_GAP:
            first = merged[j]
            targets = dict(first.targets)
            for channel, value in key.targets:
                if abs(value) > abs(targets.get(channel, 0.0)):
                    targets[channel] = value
            last_release = key.release if key.stop >= first.stop else first.release
            merged[j] = Key(
                f"{first.signal}+{key.signal}",
                first.lexeme,
                first.modality,
                first.start,
                max(first.stop, key.stop),
                first.attack,
                last_release,
                tuple(sorted(targets.items())),
                first.repeat,
                first.oscillate,
            )
            continue
        merged[i] = key
        open_key[group] = i
    return [merged[i] for i in sorted(merged)]


def _timing(action: Action, modality: str, signal: TimelineSignal) -> tuple[float, float]:
    """The occurrence's own envelope (a dialogue's occurrences carry one), else the lexeme's."""
    if signal.envelope is not None:
        return signal.envelope.attack, signal.envelope.release
    return phases(modality, signal.stop - signal.start, action.attack, action.release)


def build_track(timeline: Timeline, rig: Rig, resolver: Resolver) -> Track:
    """Keys for every occurrence that resolves; markers and one note for those that do not."""
    index = rig.channel_index
    keys: list[Key] = []
    markers: list[Marker] = []
    bodies: list[Marker] = []
    notes: dict[str, str] = {}
    for signal in timeline.signals:
        modality = modality_of(signal.modality, split_lexeme(signal.lexeme))
        action = resolver.resolve(signal.lexeme, modality)
        if action is None:
            if signal.motion is not None and signal.motion.get("file"):
                bodies.append(Marker(signal.id, signal.lexeme, modality, signal.start, signal.stop))
            else:
                markers.append(Marker(signal.id, signal.lexeme, modality, signal.start, signal.stop))
                hint = "generate its motion with --animate, or add it" if signal.motion is not None else "add it"
                notes.setdefault(
                    signal.lexeme,
                    f"lexeme {signal.lexeme!r} (signal {signal.id}) has no face, head, gaze or torso "
                    f"mapping: shown as a labelled marker ({hint} to a --lexicon table)",
                )
            continue
        if action.unsupported:
            units = ", ".join(f"AU{n}" for n in action.unsupported)
            notes.setdefault(
                f"{signal.lexeme}/units",
                f"lexeme {signal.lexeme!r} ({action.source}) uses {units}, which the face does not draw",
            )
        targets: dict[int, float] = {}
        for channel, value in action.targets:
            targets[index[channel]] = targets.get(index[channel], 0.0) + value
        attack, release = _timing(action, modality, signal)
        scale = signal.envelope.intensity if signal.envelope is not None else 1.0
        keys.append(
            Key(
                signal.id,
                signal.lexeme,
                modality,
                signal.start,
                signal.stop,
                round(attack, 4),
                round(release, 4),
                tuple((c, round(v * scale, 4)) for c, v in sorted(targets.items())),
                action.repeat,
                action.oscillate,
            )
        )
    clamped = tuple(i for i, name in enumerate(rig.channels) if name.startswith("AU"))
    merged = tuple(merge_back_to_back(keys))
    return Track(merged, tuple(markers), tuple(notes.values()), clamped, len(rig.channels), tuple(bodies))

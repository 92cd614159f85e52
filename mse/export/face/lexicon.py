"""Lexemes to face, head, gaze and torso channels: tables as data (docs/face.md).

A lexeme resolves, first match wins, through: the user's tables (``--lexicon``, later
files first), Greta's ``facelibrary.xml`` (``--face-library``: face and gaze lexemes),
Greta's ``HeadGestures.xml`` (``--head-library``: head lexemes), the table shipped in the
package (``lexicon.toml``), then two naming rules: ``AU12`` (any FACS number) and
direction words (``look_up_left``, ``head_down_right``) for gaze and head signals.
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from functools import cache
from importlib import resources
from pathlib import Path
from typing import Any

from mse.diagnostics import Diagnostic, MseError, Span
from mse.export.face.actions import Action, unit_targets
from mse.export.lexemes import Lexeme, modality_of, split_lexeme
from mse.export.realizer_libraries import ActionUnit, FaceLibrary, load_face_library

_GROUPS: Mapping[str, Mapping[str, str]] = {
    "head": {"yaw": "head_yaw", "pitch": "head_pitch", "roll": "head_roll", "forward": "head_forward"},
    "gaze": {"x": "gaze_x", "y": "gaze_y"},
    "torso": {"pitch": "torso_pitch", "roll": "torso_roll", "forward": "torso_forward", "shrug": "shrug"},
}
_AU_KEY = re.compile(r"^AU(\d+)([LR]?)$", re.IGNORECASE)
_KNOWN_KEYS = {"aliases", "au", "head", "gaze", "torso", "attack", "release", "repeat", "oscillate"}
BUNDLED = "mse lexicon"


def _actions_from_units(units: Iterable[ActionUnit], source: str) -> Action:
    targets: list[tuple[str, float]] = []
    missing: list[int] = []
    for unit in units:
        found, drawn = unit_targets(unit.number, unit.side, unit.intensity)
        targets += found
        if not drawn:
            missing.append(unit.number)
    facs = tuple((unit.number, unit.intensity, unit.side) for unit in units)
    return Action(tuple(targets), source, unsupported=tuple(sorted(set(missing))), units=facs)


# -- tables -------------------------------------------------------------------------------
def _fail(where: str, message: str) -> MseError:
    return MseError([Diagnostic("E214", message, Span(where))])


def _number(value: Any, where: str, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise _fail(where, f"{what} must be a finite number")
    if abs(value) > 1000:
        raise _fail(where, f"{what} = {value} is out of range (at most 1000 in size)")
    return float(value)


def action_from_entry(entry: Mapping[str, Any], source: str, where: str) -> Action:
    """One table entry (see ``lexicon.toml``) as an :class:`Action`; bad entries raise E214."""
    unknown = sorted(set(entry) - _KNOWN_KEYS)
    if unknown:
        raise _fail(where, f"unknown key(s) {', '.join(unknown)} (known: {', '.join(sorted(_KNOWN_KEYS))})")
    targets: list[tuple[str, float]] = []
    missing: list[int] = []
    units: list[tuple[int, float, str]] = []
    for key, value in dict(entry.get("au", {})).items():
        match = _AU_KEY.match(key)
        if match is None:
            raise _fail(where, f"au key {key!r} must look like AU12, AU12L or AU12R")
        side = {"L": "LEFT", "R": "RIGHT"}.get(match.group(2).upper(), "BOTH")
        intensity = _number(value, where, f"au.{key}")
        units.append((int(match.group(1)), intensity, side))
        found, drawn = unit_targets(int(match.group(1)), side, intensity)
        targets += found
        if not drawn:
            missing.append(int(match.group(1)))
    for group, channels in _GROUPS.items():
        for key, value in dict(entry.get(group, {})).items():
            if key not in channels:
                raise _fail(where, f"{group}.{key} is not one of {', '.join(channels)}")
            targets.append((channels[key], _number(value, where, f"{group}.{key}")))
    attack = _number(entry["attack"], where, "attack") if "attack" in entry else None
    release = _number(entry["release"], where, "release") if "release" in entry else None
    repeat = None
    if "repeat" in entry:
        spec = dict(entry["repeat"])
        every = _number(spec.get("every", 1.0), where, "repeat.every")
        length = _number(spec.get("length", 0.25), where, "repeat.length")
        if every <= 0 or length <= 0:
            raise _fail(where, "repeat.every and repeat.length must be positive")
        repeat = (every, length)
    oscillate = None
    if "oscillate" in entry:
        spec = dict(entry["oscillate"])
        period = _number(spec.get("period", 0.6), where, "oscillate.period")
        shape = spec.get("shape", "sine")
        if period <= 0 or shape not in ("sine", "bump"):
            raise _fail(where, "oscillate needs a positive period and shape 'sine' or 'bump'")
        oscillate = (period, str(shape))
    for value in (attack, release):
        if value is not None and value < 0:
            raise _fail(where, "attack and release must not be negative")
    return Action(
        tuple(targets), source, attack, release, repeat, oscillate, tuple(sorted(set(missing))), tuple(units)
    )


def parse_table(text: str, source: str, where: str) -> dict[str, Action]:
    """Name (lower case, or ``class=name``) -> action, for one TOML table."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise _fail(where, f"not a valid TOML lexeme table: {error}") from None
    except RecursionError:
        raise _fail(where, "not a valid TOML lexeme table: arrays or tables nest too deeply") from None
    table: dict[str, Action] = {}
    for name, entry in data.items():
        if not isinstance(entry, dict):
            raise _fail(where, f"{name!r} must be a table ([{name}])")
        action = action_from_entry(entry, source, f"{where}: [{name}]")
        aliases = entry.get("aliases", [])
        if not isinstance(aliases, list) or not all(isinstance(a, str) for a in aliases):
            raise _fail(where, f"[{name}] aliases must be a list of names")
        for key in (name, *aliases):
            table[key.strip().lower()] = action
    return table


def load_table(path: Path) -> dict[str, Action]:
    from mse.input_files import decode_utf8, read_input

    # Regular files only, size-capped, UTF-8 (mse.fileio: the one reader of files).
    text = decode_utf8(read_input(path, what="lexeme table"), str(path), what="lexeme table")
    return parse_table(text, path.name, str(path))


@cache
def bundled_table() -> dict[str, Action]:
    text = resources.files("mse.export.face").joinpath("lexicon.toml").read_text(encoding="utf-8")
    return parse_table(text, BUNDLED, "mse/export/face/lexicon.toml")


# -- naming rules -------------------------------------------------------------------------
_DIRECTIONS: Mapping[str, tuple[float, float]] = {
    "left": (1.0, 0.0),
    "right": (-1.0, 0.0),
    "up": (0.0, -1.0),
    "down": (0.0, 1.0),
}


def _direction(name: str) -> tuple[float, float] | None:
    words = re.split(r"[^a-z]+", name.lower())
    found = [_DIRECTIONS[w] for w in words if w in _DIRECTIONS]
    if not found:
        return None
    return sum(x for x, _ in found), sum(y for _, y in found)


def rule_action(lexeme: Lexeme, modality: str) -> Action | None:
    """``AU12`` names and direction words for gaze/head signals."""
    match = _AU_KEY.match(lexeme.name)
    if match is not None:
        side = {"L": "LEFT", "R": "RIGHT"}.get(match.group(2).upper(), "BOTH")
        found, drawn = unit_targets(int(match.group(1)), side, 1.0)
        unsupported = () if drawn else (int(match.group(1)),)
        return Action(tuple(found), "FACS name", unsupported=unsupported, units=((int(match.group(1)), 1.0, side),))
    direction = _direction(lexeme.name)
    if direction is None:
        return None
    x, y = direction
    if modality == "gaze":
        return Action((("gaze_x", x), ("gaze_y", y)), "direction words")
    if modality == "head":
        return Action((("head_yaw", 28.0 * x), ("head_pitch", 16.0 * y)), "direction words")
    return None


# -- the resolver -------------------------------------------------------------------------
@dataclass(frozen=True)
class FaceSources:
    """What the user gives: their own tables and Greta's realizer libraries."""

    tables: tuple[Path, ...] = ()
    face_library: Path | None = None
    head_library: Path | None = None


class Resolver:
    """Looks lexemes up in every source, first match wins (module docstring)."""

    def __init__(self, sources: FaceSources = FaceSources()) -> None:
        self.user_tables = [load_table(path) for path in reversed(sources.tables)]
        self.face_library: FaceLibrary | None = None
        if sources.face_library is not None:
            self.face_library = load_face_library(sources.face_library)
        self.face_library_name = sources.face_library.name if sources.face_library else ""
        self.head_library: Mapping[str, Action] = {}
        if sources.head_library is not None:
            from mse.export.face.greta_head import load_head_gestures

            self.head_library = load_head_gestures(sources.head_library)

    def resolve(self, lexeme_text: str, modality: str) -> Action | None:
        lexeme = split_lexeme(lexeme_text)
        modality = modality_of(modality, lexeme)
        keys = [lexeme.reference.lower(), lexeme.name.lower()]
        for table in self.user_tables:
            found = _lookup(table, keys)
            if found is not None:
                return found
        if self.face_library is not None and modality in ("face", "gaze", ""):
            units = self.face_library.resolve(lexeme)
            if units is None and not lexeme.klass:
                units = self.face_library.resolve(Lexeme("gaze" if modality == "gaze" else "faceexp", lexeme.name))
            if units is not None:
                return _actions_from_units(units, self.face_library_name)
        if self.head_library and modality in ("head", ""):
            found = self.head_library.get(lexeme.name.lower())
            if found is not None:
                return found
        found = _lookup(bundled_table(), keys)
        if found is not None:
            return found
        return rule_action(lexeme, modality)


def _lookup(table: Mapping[str, Action], keys: list[str]) -> Action | None:
    for key in keys:
        if key in table:
            return table[key]
    return None

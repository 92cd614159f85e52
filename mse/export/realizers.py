"""Realizer profiles: which realizer a BML file is written for, and the names it can play.

``--realizer generic|greta|asap`` picks a profile (docs/realizers.md):

- ``generic``: BML 1.0 core as the standard writes it (``part`` on ``<pose>``, explicit
  ``amount``, core lexemes); the default of ``--format bml``;
- ``asap``: the same BML 1.0, checked against AsapRealizer's own parser;
- ``greta``: what Greta's realizer reads and plays (faces by facelibrary name, heads by
  HeadGestures id, gestures by gestuary ``category=id``, torsos by TorsoGestures id, speech as
  plain text); the default (and only profile) of ``--format greta-bml``.

Each profile maps mse lexeme names to realizer names through a table shipped with mse
(``realizer_tables/*.toml``: mse's own names only, never a copy of a realizer's library).
With the realizer's libraries (``--library-dir``, Greta's BehaviorLexicon folder) every name is
checked the way the realizer looks it up.
"""

from __future__ import annotations

import difflib
import functools
import re
import tomllib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from mse.diagnostics import argument_error
from mse.export.lexemes import Lexeme
from mse.export.realizer_libraries import ActionUnit, GretaLibraries, load_greta_libraries

REALIZERS: tuple[str, ...] = ("generic", "greta", "asap")
#: The realizer a format is written for when ``--realizer`` is not given.
DEFAULT_REALIZER: Mapping[str, str] = {"bml": "generic", "greta-bml": "greta"}
#: Which table each profile maps names with.
_TABLE_FILES: Mapping[str, str] = {"generic": "generic.toml", "asap": "generic.toml", "greta": "greta.toml"}
_TABLE_DIR = Path(__file__).resolve().parent / "realizer_tables"
#: Modalities that share a table (BML's posture is Greta's torso).
_TABLE_MODALITY: Mapping[str, str] = {"posture": "torso"}
#: Gaze action units of Greta's face library (class ``gaze``) -> direction words.
_GAZE_AUS: Mapping[int, str] = {61: "LEFT", 62: "RIGHT", 63: "UP", 64: "DOWN"}
GAZE_DIRECTIONS: frozenset[str] = frozenset(
    {"", "UP", "DOWN", "LEFT", "RIGHT", "UPLEFT", "UPRIGHT", "DOWNLEFT", "DOWNRIGHT"}
)


@dataclass(frozen=True, slots=True)
class TableEntry:
    """One row of a mapping table: the realizer's name and, for approximations, why."""

    name: str
    note: str = ""


@dataclass(frozen=True)
class LexemeTable:
    """modality -> lower-case mse name -> :class:`TableEntry`."""

    realizer: str
    path: Path
    entries: Mapping[str, Mapping[str, TableEntry]]

    def lookup(self, modality: str, name: str) -> TableEntry | None:
        rows = self.entries.get(_TABLE_MODALITY.get(modality, modality), {})
        return rows.get(name.strip().lower())

    def targets(self, modality: str) -> frozenset[str]:
        """Every realizer name of one modality's table, lower case."""
        rows = self.entries.get(_TABLE_MODALITY.get(modality, modality), {})
        return frozenset(entry.name.lower() for entry in rows.values())


@functools.cache
def lexeme_table(realizer: str) -> LexemeTable:
    """The shipped mapping table of ``realizer`` (E130 for an unknown realizer)."""
    check_realizer(realizer)
    path = _TABLE_DIR / _TABLE_FILES[realizer]
    raw = tomllib.loads(path.read_text(encoding="utf-8"))
    entries: dict[str, dict[str, TableEntry]] = {}
    for modality, rows in raw.items():
        table: dict[str, TableEntry] = {}
        for key, value in rows.items():
            entry = TableEntry(value) if isinstance(value, str) else TableEntry(value["name"], value.get("note", ""))
            table[key.lower()] = entry
        entries[modality] = table
    return LexemeTable(realizer, path, entries)


def check_realizer(realizer: str) -> str:
    if realizer not in REALIZERS:
        known = ", ".join(REALIZERS)
        raise argument_error(f"unknown realizer {realizer!r} (known: {known})")
    return realizer


def realizer_for(fmt: str, realizer: str | None) -> str:
    """The profile ``fmt`` is written with: the one asked for, else the format's default.

    ``greta-bml`` is Greta's own dialect: only the ``greta`` profile writes it (E130)."""
    chosen = check_realizer(realizer) if realizer is not None else DEFAULT_REALIZER.get(fmt, "generic")
    if fmt == "greta-bml" and chosen != "greta":
        message = f"--format greta-bml is Greta's dialect; --realizer {chosen} writes --format bml"
        raise argument_error(message)
    return chosen


@functools.lru_cache(maxsize=8)
def _cached_libraries(directory: str, _stamp: tuple[tuple[str, int, int], ...]) -> GretaLibraries:
    return load_greta_libraries(Path(directory))


def greta_libraries(directory: Path | None) -> GretaLibraries | None:
    """Greta's libraries from ``directory``, or None; read again only when a file changed."""
    if directory is None:
        return None
    folder = Path(directory).resolve()
    try:
        stamp = tuple(sorted((p.name, p.stat().st_mtime_ns, p.stat().st_size) for p in folder.glob("*.xml")))
    except OSError:
        stamp = ()
    return _cached_libraries(str(folder), stamp)


# -- what a realizer gets for one lexeme ---------------------------------------------------------
@dataclass(frozen=True, slots=True)
class Realized:
    """The realizer's name for one signal.

    ``known``: True when the realizer's library has the name (or, without libraries, when it
    comes from the profile's table, whose targets tests check against the stock libraries);
    False when it does not; None when nothing could check it.  ``suggestion``: the closest
    library name when ``known`` is False.  ``source``: ``table``, ``library``, ``words`` or
    ``verbatim``."""

    name: str
    known: bool | None
    source: str
    note: str = ""
    suggestion: str | None = None


def _stem(text: str) -> str:
    """The first word of a name without its class: ``emotion=panic_fear_4`` -> ``panic``."""
    match = re.match(r"[a-z]+", text.rpartition("=")[2].lower())
    return match.group(0) if match else ""


def closest_name(name: str, candidates: Sequence[str]) -> str | None:
    """The library name closest to ``name``, for a did-you-mean.

    Names of one family (same first word: ``panic_fear_signal_7`` and ``panic_fear_7``) are
    compared loosely; across families only a near-identical spelling counts, so that
    ``regret_signal_1`` is never "corrected" to another emotion's ``relief_signal_1``."""
    stem = _stem(name)
    by_text = {c.lower(): c for c in candidates}
    family = [text for text in by_text if _stem(text) == stem]
    for pool, cutoff in ((family, 0.6), (list(by_text), 0.85)):
        match = difflib.get_close_matches(name.lower(), pool, n=1, cutoff=cutoff)
        if match:
            return by_text[match[0]]
    return None


def gaze_from_units(units: Sequence[ActionUnit] | None) -> str | None:
    """``DOWNLEFT`` from Greta's gaze action units (AU61 left, 62 right, 63 up, 64 down)."""
    if not units:
        return None
    return _direction({_GAZE_AUS[u.number] for u in units if u.number in _GAZE_AUS})


def gaze_from_words(name: str) -> str | None:
    """``look_down_left`` -> ``DOWNLEFT``: the words up/down/left/right of a name."""
    tokens = set(re.split(r"[^a-z]+", name.lower()))
    return _direction({w.upper() for w in ("up", "down", "left", "right") if w in tokens})


def _direction(words: set[str]) -> str | None:
    vertical = "UP" if "UP" in words else "DOWN" if "DOWN" in words else ""
    horizontal = "LEFT" if "LEFT" in words else "RIGHT" if "RIGHT" in words else ""
    return (vertical + horizontal) or None


def realize_gaze(realizer: str, lexeme: Lexeme, units: Sequence[ActionUnit] | None) -> Realized:
    """A gaze direction (``""``: straight at the target) from the table, the face library's gaze
    action units or the name's direction words; ``known`` is False when none gives one."""
    entry = lexeme_table(realizer).lookup("gaze", lexeme.name)
    if entry is not None:
        return Realized(entry.name, True, "table", entry.note)
    from_units = gaze_from_units(units)
    if from_units is not None:
        return Realized(from_units, True, "library")
    from_words = gaze_from_words(lexeme.name)
    if from_words is not None:
        return Realized(from_words, True, "words")
    return Realized("", False, "verbatim", "no direction: a straight look at the target")


def realize_greta(modality: str, lexeme: Lexeme, libraries: GretaLibraries | None) -> Realized:
    """What Greta gets for a signal of ``modality`` (face, head, gaze, gesture, torso/posture,
    speech), looked up as Greta's SignalFiller does when ``libraries`` are given."""
    table = lexeme_table("greta")
    entry = table.lookup(modality, lexeme.name)
    if modality == "gaze":
        units = libraries.face.resolve(Lexeme("gaze", lexeme.name)) if libraries is not None else None
        return realize_gaze("greta", lexeme, units)
    if modality == "speech":
        return Realized(lexeme.name, True, "verbatim")
    if modality == "face":
        name = entry.name if entry else lexeme.name
        if libraries is None:
            return Realized(name, _table_known(entry), _source(entry), _note(entry))
        found = libraries.face.resolve(Lexeme("faceexp", name)) is not None
        return _checked(name, found, entry, lambda: libraries.face.instances("faceexp"))
    if modality == "head":
        name = entry.name if entry else lexeme.name
        if libraries is None:
            return Realized(name, _table_known(entry), _source(entry), _note(entry))
        found = libraries.head.by_id(name) is not None or libraries.head.by_lexeme(name) is not None
        return _checked(name, found, entry, lambda: libraries.head.ids() + libraries.head.lexemes())
    if modality == "gesture":
        return _realize_gesture(lexeme, entry, libraries)
    if modality in ("torso", "posture"):
        name = entry.name if entry else lexeme.name
        if libraries is None:
            known = True if entry is not None or name.lower() in table.targets("torso") else None
            return Realized(name, known, _source(entry), _note(entry))
        found = libraries.torso.by_id(name) is not None
        return _checked(name, found, entry, libraries.torso.ids)
    return Realized(lexeme.name, False, "verbatim", f"Greta has no behaviour for modality {modality or '?'!r}")


def _realize_gesture(lexeme: Lexeme, entry: TableEntry | None, libraries: GretaLibraries | None) -> Realized:
    if entry is not None:
        reference = entry.name
    elif lexeme.klass:
        reference = lexeme.reference
    else:
        # A bare name: Greta needs the gestuary's category; take it when it is unambiguous.
        matches = libraries.gestuary.with_id(lexeme.name) if libraries is not None else []
        reference = matches[0].reference if len(matches) == 1 else f"gesture={lexeme.name}"
    if libraries is None:
        return Realized(reference, _table_known(entry), _source(entry), _note(entry))
    found = libraries.gestuary.find(reference) is not None
    return _checked(reference, found, entry, libraries.gestuary.references)


def _table_known(entry: TableEntry | None) -> bool | None:
    return True if entry is not None else None


def _source(entry: TableEntry | None) -> str:
    return "table" if entry is not None else "verbatim"


def _note(entry: TableEntry | None) -> str:
    return entry.note if entry is not None else ""


def _checked(name: str, found: bool, entry: TableEntry | None, candidates: Callable[[], Sequence[str]]) -> Realized:
    if found:
        return Realized(name, True, _source(entry), _note(entry))
    return Realized(name, False, _source(entry), _note(entry), closest_name(name, candidates()))

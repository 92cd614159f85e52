"""Lexeme names: splitting Greta references, BML ids, and the Greta face library.

A timeline lexeme is free text; Greta's style is ``class=name`` (``faceexp=smile``,
``gaze=look_down``, ``emotion=embarrassment_signal_10``) or a bare library id
(``embarrassment_signal_1``, ``NOD``).  Exporters need the two halves separately.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path

from mse.diagnostics import Diagnostic, MseError, Span

_NOT_ID_CHAR = re.compile(r"[^A-Za-z0-9_]+")

#: Lexeme classes that say which modality a signal belongs to when the modality is unknown.
CLASS_MODALITY: Mapping[str, str] = {
    "faceexp": "face",
    "face": "face",
    "gaze": "gaze",
    "head": "head",
    "torso": "torso",
    "posture": "posture",
    "speech": "speech",
    "gesture": "gesture",
    "emotion": "gesture",
    "beat": "gesture",
    "deictic": "gesture",
    "iconic": "gesture",
    "metaphoric": "gesture",
    "adaptor": "gesture",
}


@dataclass(frozen=True, slots=True)
class Lexeme:
    """``faceexp=smile`` -> klass ``faceexp``, name ``smile``; a bare name has klass ``""``."""

    klass: str
    name: str

    @property
    def reference(self) -> str:
        return f"{self.klass}={self.name}" if self.klass else self.name


def split_lexeme(text: str) -> Lexeme:
    klass, sep, name = text.strip().partition("=")
    if not sep:
        return Lexeme("", klass.strip())
    return Lexeme(klass.strip(), name.strip())


def modality_of(modality: str, lexeme: Lexeme) -> str:
    """The modality to export under: the declared one, else the lexeme class's."""
    declared = modality.strip().lower()
    if declared:
        return declared
    return CLASS_MODALITY.get(lexeme.klass.lower(), "")


def sanitize_id(text: str, *, prefix: str = "s_") -> str:
    """An identifier matching ``[A-Za-z_][A-Za-z0-9_]*``.

    Realizers split sync references such as ``a:start`` and ``bml1:a:end`` on ':' and
    some on '-', so every other character becomes '_'.
    """
    cleaned = _NOT_ID_CHAR.sub("_", text).strip("_") or "x"
    if cleaned[0].isdigit():
        cleaned = prefix + cleaned
    return cleaned


def unique_ids(names: Iterable[str]) -> list[str]:
    """Sanitized, unique ids for ``names`` in order; repeats get ``_2``, ``_3``..."""
    taken: set[str] = set()
    counts: dict[str, int] = {}
    result: list[str] = []
    for name in names:
        base = sanitize_id(name)
        candidate = base
        while candidate in taken:
            counts[base] = counts.get(base, 1) + 1
            candidate = f"{base}_{counts[base]}"
        taken.add(candidate)
        result.append(candidate)
    return result


def upper_token(name: str) -> str:
    """A BML-style upper-case lexeme token (``look_down`` -> ``LOOK_DOWN``)."""
    return sanitize_id(name, prefix="L").upper()


def format_seconds(value: float) -> str:
    """Seconds with at most three decimals and no exponent: ``1.5``, ``2``, ``0.125``."""
    text = f"{round(value, 3):.3f}".rstrip("0").rstrip(".")
    return "0" if text in ("", "-0") else text


# -- the Greta face library -----------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class ActionUnit:
    number: int
    intensity: float = 1.0
    side: str = "BOTH"


@dataclass(frozen=True)
class FaceLibrary:
    """``(class, instance)`` (lower case) -> action units, from Greta's ``facelibrary.xml``."""

    entries: Mapping[tuple[str, str], tuple[ActionUnit, ...]]

    def resolve(self, lexeme: Lexeme) -> tuple[ActionUnit, ...] | None:
        """The action units of ``lexeme``, or None when the library does not name it."""
        name = lexeme.name.lower()
        if lexeme.klass:
            return self.entries.get((lexeme.klass.lower(), name))
        for klass in ("faceexp", "gaze"):
            found = self.entries.get((klass, name))
            if found is not None:
                return found
        return None


def load_face_library(path: Path) -> FaceLibrary:
    """Read a Greta face library; unreadable -> E100, malformed XML -> E101 (MseError)."""
    from lxml import etree

    where = str(path)
    try:
        data = path.read_bytes()
    except OSError as error:
        raise MseError(
            [Diagnostic("E100", f"cannot read face library: {error.strerror or error}", Span(where))]
        ) from None
    # No DTDs, no entities, no network: a face library is plain data.
    parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False, huge_tree=False)
    try:
        root = etree.fromstring(data, parser)
    except etree.XMLSyntaxError as error:
        line, col = error.position
        raise MseError(
            [
                Diagnostic(
                    "E101",
                    f"face library is not well-formed XML: {error.msg}",
                    Span(where, line, col),
                )
            ]
        ) from None
    entries: dict[tuple[str, str], tuple[ActionUnit, ...]] = {}
    for expression in root.iter("expression"):
        klass = (expression.get("class") or "faceexp").strip().lower()
        instance = (expression.get("instance") or "").strip().lower()
        if not instance:
            continue
        units: list[ActionUnit] = []
        for action in expression.iter("action"):
            unit = _action_unit(action.get("name") or "", action.get("intensity"), action.get("side"))
            if unit is not None:
                units.append(unit)
        entries[(klass, instance)] = tuple(units)
    return FaceLibrary(entries)


def _action_unit(name: str, intensity: str | None, side: str | None) -> ActionUnit | None:
    match = re.fullmatch(r"\s*AU\s*(\d+)\s*", name, flags=re.IGNORECASE)
    if match is None:
        return None
    try:
        value = float(intensity) if intensity is not None else 1.0
    except ValueError:
        value = 1.0
    side_name = (side or "BOTH").strip().upper()
    if side_name not in ("LEFT", "RIGHT", "BOTH"):
        side_name = "BOTH"
    return ActionUnit(int(match.group(1)), max(0.0, min(1.0, value)), side_name)

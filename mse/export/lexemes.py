"""Lexeme names: splitting Greta references and BML ids.

A timeline lexeme is free text; Greta's style is ``class=name`` (``faceexp=smile``,
``gaze=look_down``, ``emotion=embarrassment_signal_10``) or a bare library id
(``embarrassment_signal_1``, ``NOD``).  Exporters need the two halves separately.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

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


"""Where the package's data lives: the grammar, the schema and the bundled behaviour sets.

In a wheel they are copied inside the package (``mse/grammar``, ``mse/behaviour_sets``);
in a source checkout they sit beside the package at the repository root.
"""

from __future__ import annotations

import functools
from pathlib import Path

_PACKAGE_DIR = Path(__file__).resolve().parent


def _data_dir(name: str) -> Path:
    inside = _PACKAGE_DIR / name
    if inside.is_dir():
        return inside
    return _PACKAGE_DIR.parent / name


@functools.cache
def grammar_dir() -> Path:
    return _data_dir("grammar")


@functools.cache
def behaviour_sets_dir() -> Path:
    return _data_dir("behaviour_sets")


def bundled_names() -> list[str]:
    """Names of the bundled expressions (file stems), sorted."""
    directory = behaviour_sets_dir()
    if not directory.is_dir():
        return []
    return sorted(p.stem for p in directory.glob("*.xml"))


def bundled_path(name: str) -> Path | None:
    """The bundled file for ``name`` (with or without ``.xml``), or None."""
    stem = name[:-4] if name.endswith(".xml") else name
    candidate = behaviour_sets_dir() / f"{stem}.xml"
    return candidate if candidate.is_file() else None


DEFAULT_EXPRESSION = "embarrassment"

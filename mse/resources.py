"""Where the package's data lives: the grammar, the schema and the bundled behaviour sets.

In a wheel they are copied inside the package (``mse/grammar``, ``mse/behaviour_sets``);
in a source checkout they sit beside the package at the repository root.
"""

from __future__ import annotations

import functools
import os
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


#: Folders of the user's own behaviour sets, searched by name before the bundled ones
#: (``os.pathsep``-separated, like PATH).
SEARCH_PATH_VARIABLE = "MSE_PATH"


def search_path() -> list[Path]:
    """The folders a set's name is looked up in: ``$MSE_PATH``'s, in order, then the bundled sets."""
    entries = os.environ.get(SEARCH_PATH_VARIABLE, "").split(os.pathsep)
    return [Path(entry) for entry in entries if entry] + [behaviour_sets_dir()]


def named_sets() -> dict[str, Path]:
    """Every set reachable by name: stem -> file (the first folder of :func:`search_path` wins)."""
    found: dict[str, Path] = {}
    for folder in search_path():
        if not folder.is_dir():
            continue
        for path in sorted(folder.glob("*.xml")):
            if path.is_file():
                found.setdefault(path.stem, path)
    return dict(sorted(found.items()))


def named_set(name: str) -> Path | None:
    """The file a name stands for (with or without ``.xml``): ``$MSE_PATH`` first, then bundled."""
    stem = name[:-4] if name.endswith(".xml") else name
    if not stem or os.sep in stem or (os.altsep and os.altsep in stem) or stem in (".", ".."):
        return None
    for folder in search_path():
        candidate = folder / f"{stem}.xml"
        if candidate.is_file():
            return candidate
    return None


def bundled_path(name: str) -> Path | None:
    """The bundled file for ``name`` (with or without ``.xml``), or None."""
    stem = name[:-4] if name.endswith(".xml") else name
    candidate = behaviour_sets_dir() / f"{stem}.xml"
    return candidate if candidate.is_file() else None


DEFAULT_EXPRESSION = "embarrassment"

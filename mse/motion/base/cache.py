"""The one in-process cache of both motion methods: parsed clips, pose and LMA features,
RMLR saliencies, modulated paths (LMA + HMM) and trained models (HSMM).

Bounded: at most :data:`MAX_ENTRIES` entries, the least recently used dropped first, so a
long-lived process (``mse serve``, a bench over thousands of clips) does not grow without
limit. Keys name their kind first (``("motion", path, ...)``) so kinds never collide. The
disk caches of the methods are separate (``cache_dir``), used only in a private folder
(:func:`disk_entry`).
"""

from __future__ import annotations

import os
from collections import OrderedDict
from collections.abc import Callable, Hashable
from pathlib import Path
from typing import Any, TypeVar

from mse.fileio import private_folder

__all__ = ["MAX_ENTRIES", "clear", "disk_entry", "forget", "remembered"]

#: entries kept (a Bandai dataset 2 action of 208 clips needs about three per clip)
MAX_ENTRIES = 4096

_T = TypeVar("_T")
_ENTRIES: OrderedDict[Hashable, Any] = OrderedDict()


def remembered(key: Hashable, build: Callable[[], _T]) -> _T:
    """The value cached under ``key``, else ``build()`` (then cached)."""
    if key in _ENTRIES:
        _ENTRIES.move_to_end(key)
        value: _T = _ENTRIES[key]
        return value
    value = build()
    _ENTRIES[key] = value
    while len(_ENTRIES) > MAX_ENTRIES:
        _ENTRIES.popitem(last=False)
    return value


def forget(kind: str) -> None:
    """Drop every entry whose key starts with ``kind``."""
    for key in [k for k in _ENTRIES if isinstance(k, tuple) and k and k[0] == kind]:
        del _ENTRIES[key]


def clear() -> None:
    _ENTRIES.clear()


def disk_entry(cache_dir: str | os.PathLike[str] | None, name: str) -> Path | None:
    """The file ``name`` of a disk cache folder, or None (no disk cache) when there is no
    folder or it is not private to this user (:func:`mse.fileio.private_folder`, the
    compiled-model cache's rule): entries someone else could plant are never read."""
    if cache_dir is None:
        return None
    folder = Path(cache_dir)
    return folder / name if private_folder(folder) else None

"""Progress bars for long work, on the terminal only (tqdm, imported when a bar is shown).

Library code wraps its long loops in :func:`bar`; a bar is drawn only when the command line
asked for them (:func:`enable`, which every ``mse`` command calls unless ``--quiet``), and
stdout and stderr are both a terminal: piped or redirected output never gets one, and the
bar itself goes to stderr, never into the data on stdout.  ``MSE_PROGRESS=1`` forces bars
on (for a terminal that is not detected as one, and for tests), ``MSE_PROGRESS=0`` off.
Python API callers get no bar unless they call :func:`enable` themselves.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Any, Protocol, TypeVar

_requested = False
T = TypeVar("T")
#: Seconds before a bar appears: work done sooner shows nothing (0 when forced on).
DELAY = 0.5


class Bar(Protocol):
    def update(self, n: int = 1) -> object: ...


class _Silent:
    def update(self, n: int = 1) -> None:
        return None


def enable(on: bool = True) -> None:
    """Let :func:`bar` draw (the CLI calls this unless ``--quiet``)."""
    global _requested
    _requested = on


def _terminal() -> bool:
    try:
        return sys.stderr.isatty() and sys.stdout.isatty()
    except (AttributeError, ValueError):  # closed or replaced streams
        return False


def shown() -> bool:
    """True when a bar started now would be drawn."""
    forced = os.environ.get("MSE_PROGRESS", "")
    if forced == "0" or not _requested:
        return False
    return forced == "1" or _terminal()


@contextmanager
def bar(total: int | None, description: str, unit: str = "it") -> Iterator[Bar]:
    """A progress bar of ``total`` steps on stderr, or a silent stand-in."""
    if not shown():
        yield _Silent()
        return
    from tqdm import tqdm

    delay = 0.0 if os.environ.get("MSE_PROGRESS") == "1" else DELAY
    options: dict[str, Any] = {"total": total, "desc": description, "unit": unit, "file": sys.stderr}
    with tqdm(leave=False, dynamic_ncols=True, mininterval=0.2, delay=delay, **options) as drawn:
        yield drawn


def each(items: Sequence[T], description: str, unit: str = "it") -> Iterator[T]:
    """The items of ``items``, one bar step per item (see :func:`bar`)."""
    with bar(len(items), description, unit) as steps:
        for item in items:
            yield item
            steps.update()

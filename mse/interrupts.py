"""Ctrl-C on the command line: a KeyboardInterrupt, but never delivered inside an import.

An interrupt that lands while Python imports a module is mangled by the import machinery
rather than raised: numpy turns it into an ImportError ("Importing the numpy C-extensions
failed"), importlib's module-lock callbacks print it as "Exception ignored" and carry on, so
the command runs to its end.  Both were seen by interrupting ``mse sample --solver cpsat``
while ortools loads.  So an interrupt that arrives while an import is running is held back
and delivered :data:`RETRY_S` later, when the import has finished.  Only the command line
installs this (:func:`install`); library users keep Python's own handler.
"""

from __future__ import annotations

import signal
from types import FrameType

#: How long (s) a held-back interrupt waits before it is tried again.
RETRY_S = 0.05


def _importing(frame: FrameType | None) -> bool:
    while frame is not None:
        if frame.f_code.co_filename.startswith("<frozen importlib"):
            return True
        frame = frame.f_back
    return False


def _interrupt(_signum: int, frame: FrameType | None) -> None:
    if _importing(frame):
        signal.setitimer(signal.ITIMER_REAL, RETRY_S)  # SIGALRM comes back here
        return
    raise KeyboardInterrupt


def install() -> None:
    """SIGINT raises KeyboardInterrupt, held back while a module is being imported."""
    if not hasattr(signal, "setitimer"):  # pragma: no cover - not on POSIX: Python's own handler
        return
    signal.signal(signal.SIGALRM, _interrupt)
    signal.signal(signal.SIGINT, _interrupt)

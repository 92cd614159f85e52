"""Helpers shared by the sub-commands: diagnostics on stderr, models from arguments,
output to stdout or to a file written atomically."""

from __future__ import annotations

import os
import sys
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, TextIO

from mse.diagnostics import Diagnostic, MseError, Span
from mse.fileio import write_atomic

if TYPE_CHECKING:
    from mse.timeline import Timeline

_COLOURS = {"E": "\033[31m", "W": "\033[33m"}
_RESET = "\033[0m"


def use_colour(stream: TextIO) -> bool:
    if os.environ.get("NO_COLOR"):
        return False
    return hasattr(stream, "isatty") and stream.isatty()


def print_diagnostics(diagnostics: Iterable[Diagnostic], stream: TextIO | None = None) -> None:
    out = stream or sys.stderr
    colour = use_colour(out)
    for diagnostic in diagnostics:
        line = diagnostic.render()
        if colour:
            code = diagnostic.code
            line = line.replace(f" {code} ", f" {_COLOURS.get(code[0], '')}{code}{_RESET} ", 1)
        print(line, file=out)


def print_error(error: MseError) -> int:
    print_diagnostics(error.diagnostics)
    return 1


def emit(text: str, output: str | None) -> None:
    """Write ``text`` to ``output`` atomically, or to stdout when no output is given."""
    if output and output != "-":
        write_atomic(output, text)
    else:
        sys.stdout.write(text)
        if text and not text.endswith("\n"):
            sys.stdout.write("\n")
        sys.stdout.flush()


def read_stdin_bytes() -> bytes:
    return sys.stdin.buffer.read()


def read_timelines(name: str) -> list[Timeline]:
    """The timelines in file ``name`` ('-': stdin): one, a JSON array, or JSON lines.
    Unreadable or malformed input raises MseError (E100, E212)."""
    from mse.timeline import loads_many

    if name == "-":
        return loads_many(sys.stdin.read(), path="<stdin>")
    try:
        text = Path(name).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as error:
        reason = getattr(error, "strerror", None) or str(error)
        raise MseError([Diagnostic("E100", f"cannot read timeline: {reason}", Span(name))]) from None
    return loads_many(text, path=name)

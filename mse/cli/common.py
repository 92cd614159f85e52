"""Helpers shared by the sub-commands: diagnostics on stderr, models from arguments,
output to stdout or to a file written atomically."""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Iterable
from typing import TYPE_CHECKING, TextIO

from mse.diagnostics import Diagnostic, MseError
from mse.fileio import write_atomic
from mse.input_files import decode_utf8, read_input, read_stdin
from mse.limits import MAX_INPUT_BYTES

if TYPE_CHECKING:
    from mse.timeline import Timeline

_COLOURS = {"E": "\033[31m", "W": "\033[33m"}
_RESET = "\033[0m"


def add_quiet(parser: argparse.ArgumentParser) -> None:
    """``-q/--quiet``: no progress bar (bars show only on a terminal anyway: mse/progress.py)."""
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bar on the terminal")


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


def emit(text: str, output: str | None, *, inputs: Iterable[str | os.PathLike[str]] = ()) -> None:
    """Write ``text`` to ``output`` (:func:`mse.fileio.write_atomic`: never over one of the
    command's ``inputs``; failures raise MseError E105), or to stdout when no output is given."""
    if output and output != "-":
        write_atomic(output, text, inputs=inputs)
    else:
        sys.stdout.write(text)
        if text and not text.endswith("\n"):
            sys.stdout.write("\n")
        sys.stdout.flush()


def read_stdin_bytes() -> bytes:
    """Standard input, at most MAX_INPUT_BYTES (E104 beyond)."""
    return read_stdin(MAX_INPUT_BYTES)


def read_timelines(name: str) -> list[Timeline]:
    """The timelines in file ``name`` ('-': stdin): one, a JSON array, or JSON lines.
    Unreadable or malformed input raises MseError (E100, E104, E212)."""
    from mse.timeline import loads_many

    where = "<stdin>" if name == "-" else name
    data = read_input(name, what="timeline")
    return loads_many(decode_utf8(data, where, code="E212", what="timeline"), path=where)

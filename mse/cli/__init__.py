"""The ``mse`` command line: a thin ``main(argv) -> int`` over the library API.

Each sub-command lives in its own module ``mse.cli.cmd_<name>`` exposing
``register(subparsers)``; the module must stay cheap to import (heavy imports go inside
the handler) so that ``mse sample`` starts fast.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import sys
from collections.abc import Sequence

#: Sub-command modules, in the order ``mse --help`` lists them.
COMMAND_MODULES: tuple[str, ...] = (
    "cmd_compile",
    "cmd_sample",
    "cmd_check",
    "cmd_live",
    "cmd_serve",
    "cmd_repair",
    "cmd_lint",
    "cmd_list",
    "cmd_export",
    "cmd_render",
    "cmd_import_greta",
    "cmd_learn",
    "cmd_animate",
    "cmd_lma",
    "cmd_style",
    "cmd_study",
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="mse",
        description="Compile, check and solve multimodal sequential expressions of emotion.",
    )
    from mse import __version__

    parser.add_argument("--version", action="version", version=f"mse {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMAND_MODULES:
        module = importlib.import_module(f"mse.cli.{name}")
        module.register(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run one ``mse`` command; returns the exit code (0 ok, 1 input errors, 2 usage/infeasible)."""
    parser = build_parser()
    try:
        args = parser.parse_args(list(argv) if argv is not None else None)
    except SystemExit as exit_request:  # argparse exits on --help and on usage errors
        return int(exit_request.code or 0)
    handler = getattr(args, "handler", None)
    if handler is None:
        parser.print_help(sys.stderr)
        return 2
    from mse import progress
    from mse.extras import MissingExtra
    from mse.fileio import Terminated
    from mse.input_files import recording_reads

    # Long work shows a bar on a terminal (never when piped, never under --quiet).
    progress.enable(not getattr(args, "quiet", False))
    try:
        with recording_reads():  # no output may replace a file the command read (mse/fileio.py)
            return int(handler(args))
    except MissingExtra as missing:  # an optional part that is not installed (mse/extras.py)
        print(f"error: mse {args.command} needs the {missing.extra!r} extra: pip install 'mse[{missing.extra}]'",
              file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(INTERRUPTED, file=sys.stderr)
        return 130
    except ImportError as error:
        # Ctrl-C while a compiled extension initialises (ortools) comes back as an ImportError
        if not isinstance(error.__cause__ or error.__context__, KeyboardInterrupt):
            raise
        print(INTERRUPTED, file=sys.stderr)
        return 130
    except Terminated as signal_received:  # temporary files were removed on the way out
        return 128 + signal_received.signum
    except BrokenPipeError:
        return 0
    except OSError as error:
        if not _stdout_failed(error):
            raise
        return _stdout_error(error)


INTERRUPTED = "mse: interrupted"


class _ClosedStream:
    """Stands for a standard stream the process was started without (``>&-``, ``<&-``):
    reading or writing it fails with EBADF like any other unreadable input or unwritable
    output (other attributes are missing, as on any object)."""

    @staticmethod
    def _closed() -> OSError:
        import errno

        return OSError(errno.EBADF, "the stream is closed")

    @property
    def buffer(self) -> object:
        raise self._closed()

    def write(self, _text: str) -> int:
        raise self._closed()

    def writelines(self, _lines: object) -> None:
        raise self._closed()

    def read(self, _size: int = -1) -> str:
        raise self._closed()

    def readline(self, _size: int = -1) -> str:
        raise self._closed()

    def fileno(self) -> int:
        raise self._closed()

    def isatty(self) -> bool:
        return False

    def flush(self) -> None:  # nothing was written (the interpreter flushes at exit)
        return None


def _stdout_failed(error: OSError) -> bool:
    """True for the errors of writing standard output (a full disk, a closed stream, a
    broken device) that reach here: a command turns its own file errors into diagnostics."""
    import errno

    return error.errno in (errno.ENOSPC, errno.EDQUOT, errno.EBADF, errno.EIO, errno.EFBIG)


def _stdout_error(error: OSError) -> int:
    """``<stdout>: E105 cannot write output: REASON`` and exit 1; what is left in the buffer
    goes nowhere (so the interpreter's own flush at exit does not fail again)."""
    import os

    from mse.diagnostics import Diagnostic, Span

    print(Diagnostic("E105", f"cannot write output: {error.strerror or error}", Span("<stdout>")).render(),
          file=sys.stderr)
    with contextlib.suppress(OSError, ValueError, AttributeError):
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    return 1


def console_main() -> None:
    """Entry point of the ``mse`` console script."""
    import os

    # Started without stdin or stdout: they fail when used, as a closed stream does.
    if sys.stdin is None:
        sys.stdin = _ClosedStream()
    if sys.stdout is None:
        sys.stdout = _ClosedStream()
    if sys.stderr is None:  # messages then go nowhere, never to stdout
        sys.stderr = open(os.devnull, "w")  # noqa: SIM115 - for the life of the process
    try:
        from mse import interrupts
        from mse.fileio import install_termination_handler

        interrupts.install()
        install_termination_handler()
        code = main()
    except KeyboardInterrupt:  # during start-up, before a command runs
        print(INTERRUPTED, file=sys.stderr)
        code = 130
    try:
        sys.stdout.flush()
    except BrokenPipeError:
        pass
    except OSError as error:
        code = _stdout_error(error)
    raise SystemExit(code)

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
        return 130
    except Terminated as signal_received:  # temporary files were removed on the way out
        return 128 + signal_received.signum
    except BrokenPipeError:
        return 0


def console_main() -> None:
    """Entry point of the ``mse`` console script."""
    from mse.fileio import install_termination_handler

    install_termination_handler()
    code = main()
    with contextlib.suppress(BrokenPipeError):
        sys.stdout.flush()
    raise SystemExit(code)

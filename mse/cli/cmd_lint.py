"""``mse lint PATH...``: errors and warnings with codes, in several formats."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from mse.cli.common import add_quiet, emit, print_diagnostics
from mse.diagnostics import Severity

FORMATS = ("text", "json", "github", "sarif")


def _codes(value: str) -> list[str]:
    return [part.strip() for part in value.split(",") if part.strip()]


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "lint",
        help="lint behaviour sets (files, folders or bundled names)",
        description="Report errors (E), warnings (W) and notes (N) of behaviour-set files, the solver-backed "
        "W4xx rules included unless --no-deep. A folder without any *.xml is a W300 warning. Exit 1 "
        "on errors, or on warnings with --strict; 2 when --select/--ignore names no rule code.",
    )
    parser.add_argument("paths", nargs="+", help="files, folders (searched for *.xml) or bundled names")
    add_quiet(parser)
    parser.add_argument(
        "--format",
        choices=FORMATS,
        default="text",
        help="text (default), json, github (workflow annotations) or sarif (SARIF 2.1.0 for code scanning)",
    )
    parser.add_argument("--select", type=_codes, default=[], help="only these code prefixes, e.g. W30,W401")
    parser.add_argument("--ignore", type=_codes, default=[], help="skip these code prefixes")
    parser.add_argument("--strict", action="store_true", help="warnings (not notes) make the exit code 1")
    parser.add_argument("--no-deep", dest="deep", action="store_false", help="skip the solver-backed rules (W4xx)")
    parser.add_argument(
        "--duration", type=float, default=10.0, help="timeline duration for the solver-backed rules (default 10 s)"
    )
    parser.add_argument(
        "--deep-budget", type=float, default=4.0, metavar="SECONDS",
        help="CPU seconds per file for the solver-backed questions (default 4; whether a timeline exists is "
        "always answered; questions left are listed in a W400 note); 0: no limit",
    )
    parser.add_argument(
        "--realizer",
        choices=("greta",),
        help="also report signals this realizer cannot resolve in its libraries (W308; needs --library-dir); "
        "only Greta resolves lexemes through libraries (AsapRealizer and the generic BML accept any lexeme)",
    )
    parser.add_argument(
        "--library-dir", metavar="DIR", help="the realizer's libraries (Greta's BehaviorLexicon folder)"
    )
    parser.add_argument("-o", "--output", help="write the report to this file (atomically)")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from mse.api import expand_paths, lint
    from mse.cli.common import print_error
    from mse.cli.lint_formats import FORMATTERS
    from mse.diagnostics import MseError

    deep = args.deep and _deep_available()
    try:
        diagnostics = lint(
            args.paths,
            select=args.select,
            ignore=args.ignore,
            deep=deep,
            duration=args.duration,
            deep_budget=None if args.deep_budget == 0 else args.deep_budget,
            realizer=args.realizer,
            library_dir=args.library_dir,
        )
    except MseError as error:  # a usage error: --select/--ignore naming no rule, a bad --duration
        print_diagnostics(error.diagnostics)
        return 2
    try:
        if args.format == "text" and not args.output:
            print_diagnostics(diagnostics, sys.stdout)
        else:
            emit(FORMATTERS[args.format](diagnostics), args.output, inputs=[*args.paths, *expand_paths(args.paths)])
    except MseError as error:  # -o cannot be written (E105)
        return print_error(error)
    errors = sum(d.is_error for d in diagnostics)
    notes = sum(d.severity is Severity.NOTE for d in diagnostics)
    warnings = len(diagnostics) - errors - notes
    if args.format == "text":
        tail = f", {notes} note(s)" if notes else ""
        print(f"{errors} error(s), {warnings} warning(s){tail}", file=sys.stderr)
    return 1 if errors or (args.strict and warnings) else 0


def _deep_available() -> bool:
    import importlib.util

    return importlib.util.find_spec("mse.solve.cpsat.deep_lint") is not None

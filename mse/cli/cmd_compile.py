"""``mse compile FILE``: the canonical IR as JSON."""

from __future__ import annotations

import argparse
from typing import Any

from mse.cli.common import emit, print_diagnostics, print_error
from mse.diagnostics import MseError


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "compile",
        help="parse and validate a behaviour set; print its canonical IR as JSON",
        description="Parse and validate a behaviour-set file (or a bundled expression by name) "
        "and print the canonical IR as JSON. Every error of the file is reported as "
        "path:line:col: CODE message; exit 1 on errors.",
    )
    parser.add_argument("source", help="a behaviour-set XML file or a bundled expression name")
    parser.add_argument("-o", "--output", help="write the JSON to this file (atomically)")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from mse.api import compile_source, resolve_path
    from mse.ir.canonical import model_dumps

    try:
        path = resolve_path(args.source)
    except MseError as error:
        return print_error(error)
    model, diagnostics = compile_source(path)
    print_diagnostics(diagnostics)
    if model is None:
        return 1
    try:
        emit(model_dumps(model) + "\n", args.output, inputs=[path])
    except MseError as error:
        return print_error(error)
    return 0

"""``mse list``: the bundled expressions, one line each."""

from __future__ import annotations

import argparse
from typing import Any


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "list",
        help="list the bundled expressions",
        description="List the expressions bundled with mse, one a line: name, number of signals and "
        "constraints, and the start of the description. Any of these names can stand for a file in "
        "compile, sample, check and lint.",
    )
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from mse.api import compile_source
    from mse.resources import bundled_names, bundled_path

    for name in bundled_names():
        path = bundled_path(name)
        assert path is not None
        model, _ = compile_source(path)
        if model is None:
            print(f"{name:<14} (has errors: run mse compile {name})")
            continue
        summary = model.description
        if len(summary) > 64:
            summary = summary[:63].rsplit(" ", 1)[0] + " …"
        print(f"{name:<14} {len(model.signals):>2} signals {len(model.constraints):>2} constraints  {summary}")
    return 0

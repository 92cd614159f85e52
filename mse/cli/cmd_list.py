"""``mse list``: the expressions reachable by name (``$MSE_PATH``'s folders, then bundled)."""

from __future__ import annotations

import argparse
from typing import Any


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "list",
        help="list the expressions reachable by name",
        description="List the expressions reachable by name, one a line: name, number of signals and "
        "constraints, and the start of the description; the user's own sets (in the folders of $MSE_PATH, "
        "separated like PATH, searched first) come with their folder. Any of these names can stand for a "
        "file in compile, sample, check, lint and the rest.",
    )
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from mse.api import compile_source
    from mse.resources import behaviour_sets_dir, named_sets

    bundled = behaviour_sets_dir().resolve()
    for name, path in named_sets().items():
        where = "" if path.resolve().parent == bundled else f"  [{path.parent}]"
        model, _ = compile_source(path)
        if model is None:
            print(f"{name:<14} (has errors: run mse compile {name}){where}")
            continue
        summary = model.description
        if len(summary) > 64:
            summary = summary[:63].rsplit(" ", 1)[0] + " …"
        print(f"{name:<14} {len(model.signals):>2} signals {len(model.constraints):>2} constraints  {summary}{where}")
    return 0

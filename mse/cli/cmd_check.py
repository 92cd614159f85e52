"""``mse check MODEL TIMELINE``: each violated rule of each timeline, with file:line."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from mse.cli.common import print_error, read_timelines
from mse.diagnostics import MseError


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "check",
        help="check timelines against a behaviour set",
        description="Check one timeline, a JSON array of timelines, or JSON lines against a "
        "behaviour set. Prints each violated constraint with its file:line; exit 1 if any.",
    )
    parser.add_argument("source", help="a behaviour-set file or a bundled expression name")
    parser.add_argument("timeline", help="timeline JSON file ('-' for stdin)")
    parser.add_argument("-q", "--quiet", action="store_true", help="print nothing when consistent")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from mse.api import check, load

    try:
        model = load(args.source)
        timelines = read_timelines(args.timeline)
    except MseError as error:
        return print_error(error)
    failing = 0
    for index, timeline in enumerate(timelines):
        violations = check(model, timeline)
        label = f"timeline {index + 1}" if len(timelines) > 1 else "timeline"
        if violations:
            failing += 1
            for violation in violations:
                print(f"{violation.render()} [{label}]")
    if not args.quiet:
        ok = len(timelines) - failing
        print(f"{ok} of {len(timelines)} timeline(s) consistent with {model.name}", file=sys.stderr)
    return 1 if failing else 0

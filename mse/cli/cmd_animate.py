"""``mse animate TIMELINE -o OUT/``: motion for every motion leaf of a timeline."""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from mse.ir.model import Model
    from mse.timeline import Timeline


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "animate",
        help="generate BVH motion for the motion leaves of a timeline",
        description="Generate one BVH per motion-leaf occurrence (exactly its scheduled "
        "duration), a BVH of the whole timeline and lma.json, with the LMA + HMM method "
        "(Samadani et al.). Without --library the embedded starter library is used; actions "
        "missing from a library fall back to it with a warning.",
    )
    parser.add_argument("timeline", help="timeline JSON file ('-' for stdin)")
    parser.add_argument("-o", "--output", required=True, help="output folder")
    parser.add_argument(
        "--library",
        help="motion library folder (library.json, library.csv or the Bandai layout)",
    )
    parser.add_argument(
        "--expression",
        help="behaviour set (file or bundled name) that declares the motion leaves; default: the timeline's expression",
    )
    parser.add_argument(
        "--style",
        action="append",
        default=[],
        metavar="EMOTION=STYLE",
        help="override the emotion -> library style table (repeatable)",
    )
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from mse.api import load
    from mse.cli.common import print_error, read_timelines
    from mse.diagnostics import Diagnostic, MseError, Span
    overrides = {}
    for item in args.style:
        emotion, _, style = item.partition("=")
        if not emotion or not style:
            print(f"mse animate: --style expects EMOTION=STYLE, got {item!r}", file=sys.stderr)
            return 2
        overrides[emotion] = style
    try:
        timelines = read_timelines(args.timeline)
        resolved: list[tuple[Timeline, Model]] = []
        for timeline in timelines:
            expression = args.expression or timeline.expression
            if not expression:
                message = "the timeline names no expression: use --expression"
                raise MseError([Diagnostic("E212", message, Span(args.timeline))])
            resolved.append((timeline, load(expression)))
        animate_timelines(resolved, Path(args.output), args.library, overrides)
    except MseError as error:
        return print_error(error)
    return 0


def animate_timelines(
    items: list[tuple[Timeline, Model]],
    out: Path,
    library_path: str | None,
    overrides: dict[str, str] | None = None,
) -> list[Timeline]:
    """Animate each timeline into ``out`` (``out/001``, ... when there are several), write
    ``timeline.json`` beside the clips, print warnings on stderr; returns the timelines."""
    from mse.fileio import write_atomic
    from mse.motion.animate import animate
    from mse.motion.base.library import load_library

    library = load_library(library_path) if library_path else None
    animated_all = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for index, (timeline, model) in enumerate(items):
            folder = out if len(items) == 1 else out / f"{index + 1:03d}"
            animated = animate(timeline, model, folder, library, emotion_styles=overrides or {})
            write_atomic(folder / "timeline.json", animated.dumps() + "\n")
            count = sum(1 for s in animated.signals if s.motion and "file" in s.motion)
            print(f"{folder}: {count} motion clip(s), timeline.bvh, lma.json", file=sys.stderr)
            animated_all.append(animated)
    for warning in caught:
        print(f"warning: {warning.message}", file=sys.stderr)
    return animated_all

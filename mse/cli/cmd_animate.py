"""``mse animate TIMELINE -o OUT/``: motion for every motion leaf of a timeline."""

from __future__ import annotations

import argparse
import sys
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from mse.ir.model import Model
    from mse.timeline import Timeline

from mse.cli.common import add_quiet


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
    add_quiet(parser)
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
    from mse.diagnostics import MseError, argument_error

    overrides = {}
    for item in args.style:
        emotion, _, style = item.partition("=")
        if not emotion or not style:
            return print_error(argument_error(f"--style expects EMOTION=STYLE, got {item!r}"))
        overrides[emotion] = style
    try:
        timelines = read_timelines(args.timeline)
        resolved: list[tuple[Timeline, Model]] = []
        for timeline in timelines:
            model = load(args.expression) if args.expression else _recorded_expression(timeline, args.timeline)
            _check_signals(timeline, model, args.timeline)
            resolved.append((timeline, model))
        inputs = [p for p in (args.timeline, args.library, args.expression) if p]
        animate_timelines(resolved, Path(args.output), args.library, overrides, inputs=inputs)
    except MseError as error:
        return print_error(error)
    return 0


def _recorded_expression(timeline: Timeline, where: str) -> Model:
    """The expression the timeline was sampled from: its recorded source file (a warning
    when the file changed since), its bundled name, else its expression name."""
    import hashlib

    from mse.api import load
    from mse.diagnostics import Diagnostic, MseError, Span

    source = timeline.source or {}
    if "path" in source:
        path = Path(source["path"])
        if not path.is_file():
            message = f"the timeline's expression file {path} is gone: give --expression FILE"
            raise MseError([Diagnostic("E100", message, Span(where))])
        recorded = source.get("sha256")
        from mse.input_files import read_input

        if recorded and hashlib.sha256(read_input(path)).hexdigest() != recorded:
            print(f"{path}: warning: changed since the timeline was sampled from it", file=sys.stderr)
        return load(path)
    name = source.get("bundled") or timeline.expression
    if not name:
        raise MseError([Diagnostic("E212", "the timeline names no expression: use --expression", Span(where))])
    return load(name)


def _check_signals(timeline: Timeline, model: Model, where: str) -> None:
    """Every signal of the timeline must be declared by ``model``: animating with the wrong
    expression would otherwise write no motion at all, silently."""
    from mse.diagnostics import Diagnostic, MseError, Span

    unknown = sorted({s.id for s in timeline.signals} - set(model.signal_by_id))
    if unknown:
        shown = ", ".join(unknown[:8]) + (f" and {len(unknown) - 8} more" if len(unknown) > 8 else "")
        message = (
            f"the timeline's signals {shown} are not in expression {model.name!r} ({model.path}): "
            "give the --expression the timeline was sampled from"
        )
        raise MseError([Diagnostic("E212", message, Span(where))])


def _check_style_overrides(items: list[tuple[Timeline, Model]], library: Any, overrides: dict[str, str]) -> None:
    """An override for an emotion nothing knows is a typo (``--style angr=sad``): refuse it."""
    from mse.diagnostics import argument_error
    from mse.motion.base.library import EMOTION_STYLES

    known = {name.lower() for name in EMOTION_STYLES}
    known |= {name.lower() for name in (library.emotion_styles if library is not None else {})}
    for timeline, model in items:
        known |= {timeline.expression.lower(), model.name.lower()}
        known |= {str(s.motion.attributes.get("emotion", "")).lower() for s in model.signals if s.motion}
    known.discard("")
    unknown = sorted(e for e in overrides if e.lower().removeprefix("emotion-") not in known)
    if unknown:
        message = f"--style: unknown emotion(s) {', '.join(map(repr, unknown))}; known: {', '.join(sorted(known))}"
        raise argument_error(message)


def animate_timelines(
    items: list[tuple[Timeline, Model]],
    out: Path,
    library_path: str | None,
    overrides: dict[str, str] | None = None,
    *,
    inputs: Sequence[str] = (),
) -> list[Timeline]:
    """Animate each timeline into ``out`` (``out/001``, ... when there are several), write
    ``timeline.json`` beside the clips, print warnings on stderr; returns the timelines.
    Everything is written into a temporary folder first and moved into ``out`` only when
    every timeline succeeded: an error leaves ``out`` as it was (never clips without
    their timeline.json)."""
    from mse.fileio import staged_folder, write_atomic
    from mse.motion.animate import animate
    from mse.motion.base.library import load_library

    library = load_library(library_path) if library_path else None
    if overrides:
        _check_style_overrides(items, library, overrides)
    animated_all = []
    summaries = []
    with warnings.catch_warnings(record=True) as caught, staged_folder(out, inputs=inputs, empty=True) as staging:
        warnings.simplefilter("always")
        for index, (timeline, model) in enumerate(items):
            relative = Path() if len(items) == 1 else Path(f"{index + 1:03d}")
            animated = animate(timeline, model, staging / relative, library, emotion_styles=overrides or {})
            write_atomic(staging / relative / "timeline.json", animated.dumps() + "\n")
            count = sum(1 for s in animated.signals if s.motion and "file" in s.motion)
            summaries.append(f"{out / relative}: {count} motion clip(s), timeline.bvh, lma.json")
            animated_all.append(animated)
    for summary in summaries:
        print(summary, file=sys.stderr)
    for warning in caught:
        print(f"warning: {warning.message}", file=sys.stderr)
    return animated_all

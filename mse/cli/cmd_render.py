"""``mse render TIMELINE -o clip.mp4``: the face (and body) playing a timeline, as a video.

``-o`` takes ``.mp4``, ``.webm``, ``.gif`` or ``.png`` (one frame, at ``--at``);
``--frames DIR`` writes every frame as PNG.  Lexemes resolve through ``--lexicon`` tables,
``--face-library``/``--head-library`` (Greta) and the table shipped with mse
(docs/face.md); each lexeme the face cannot show is reported once on standard error.
"""

from __future__ import annotations

import argparse
import math
import re
import sys
from pathlib import Path
from typing import Any

from mse.cli.common import add_quiet

_SIZE = re.compile(r"([1-9][0-9]{0,4})x([1-9][0-9]{0,4})")  # ASCII digits, no leading zero


def _size(text: str) -> tuple[int, int]:
    match = _SIZE.fullmatch(text.strip(" ").lower())
    if match is None:
        raise argparse.ArgumentTypeError(f"{text!r} is not WIDTHxHEIGHT (e.g. 960x540)")
    return int(match.group(1)), int(match.group(2))


def add_face_arguments(parser: argparse.ArgumentParser | argparse._ArgumentGroup) -> None:
    """Where lexemes come from (shared by render, export and sample)."""
    parser.add_argument(
        "--lexicon",
        action="append",
        type=Path,
        default=[],
        metavar="FILE",
        help="your lexeme table (TOML, the layout of mse/export/face/lexicon.toml); read before the bundled one; "
        "repeatable",
    )
    parser.add_argument("--head-library", type=Path, metavar="FILE", help="Greta HeadGestures.xml for head lexemes")


def add_video_arguments(parser: argparse.ArgumentParser | argparse._ArgumentGroup) -> None:
    """Frame size, rate and strip of a video (shared by render and ``sample --format mp4``)."""
    parser.add_argument("--size", type=_size, default=(960, 540), metavar="WxH", help="frame size (default 960x540)")
    parser.add_argument("--fps", type=float, default=25.0, help="frames per second (default 25)")
    parser.add_argument("--no-strip", action="store_true", help="leave out the timeline strip")


def video_options(args: argparse.Namespace) -> Any:
    """The VideoOptions of :func:`add_video_arguments`' values."""
    from mse.export.video import VideoOptions

    return VideoOptions(size=args.size, fps=args.fps, strip=not args.no_strip)


def add_bml_block_arguments(parser: argparse.ArgumentParser | argparse._ArgumentGroup) -> None:
    """``--composition`` and ``--bml-id`` of the BML block (shared by sample, export and live)."""
    parser.add_argument(
        "--composition",
        type=str.upper,
        choices=("MERGE", "APPEND", "REPLACE"),
        default="MERGE",
        help="BML block composition: how the realizer combines it with the blocks it is playing (default MERGE)",
    )
    parser.add_argument("--bml-id", metavar="ID", help="the BML block id (default: bml_<expression>; a dialogue's "
                        "carries its seed and length)")


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = subparsers.add_parser(
        "render",
        help="render a timeline as a video of the face (and body): mp4, webm, gif, png frames",
        description="Render a timeline (mse-timeline/1 JSON) as a video: the face, head, gaze and torso "
        "(and the body, when the timeline has motion) with the timeline strip and playhead.",
    )
    p.add_argument("timeline", help="timeline JSON file ('-' reads standard input; the first timeline is used)")
    p.add_argument("-o", "--output", type=Path, help="clip.mp4, clip.webm, clip.gif, or frame.png (one frame)")
    p.add_argument("--frames", type=Path, metavar="DIR", help="write every frame as PNG into DIR (new or empty)")
    add_video_arguments(p)
    p.add_argument("--at", type=float, default=0.0, metavar="SECONDS", help="time of the frame for a .png output")
    add_quiet(p)
    p.add_argument("--face-library", type=Path, metavar="FILE", help="Greta facelibrary.xml for face and gaze lexemes")
    add_face_arguments(p)
    p.add_argument(
        "--motion-dir",
        type=Path,
        help="folder that motion file paths are relative to (default: the timeline's folder)",
    )
    p.set_defaults(handler=run)


def video_format(path: Path) -> str | None:
    suffix = path.suffix.lower().lstrip(".")
    return suffix if suffix in ("mp4", "webm", "gif", "png") else None


def print_notes(notes: tuple[str, ...] | list[str], where: str) -> None:
    """Each lexeme the face cannot show, once (W602)."""
    from mse.diagnostics import Diagnostic, Span

    for note in notes:
        print(Diagnostic("W602", note, Span(where)).render(), file=sys.stderr)


def run(args: argparse.Namespace) -> int:
    from mse.cli.common import print_error, read_timelines
    from mse.diagnostics import Diagnostic, MseError, Span, argument_error
    from mse.export import ExportOptions
    from mse.export.video import render_still, write_frames, write_video
    from mse.fileio import write_atomic

    where = "<stdin>" if args.timeline == "-" else args.timeline
    try:
        if args.output is None and args.frames is None:
            raise argument_error("give -o FILE (.mp4 .webm .gif .png) and/or --frames DIR")
        if not math.isfinite(args.at):  # a finite time is clamped into the timeline
            raise argument_error(f"--at {args.at} must be a number of seconds")
        fmt = video_format(args.output) if args.output is not None else None
        if args.output is not None and fmt is None:
            message = f"cannot tell the format of {str(args.output)!r}: use .mp4, .webm, .gif or .png"
            raise argument_error(message)
        timelines = read_timelines(args.timeline)
        if not timelines:
            raise MseError([Diagnostic("E212", "no timeline in the input", Span(where))])
        if len(timelines) > 1:
            print(f"{where}: note: {len(timelines)} timelines, rendering the first", file=sys.stderr)
        timeline = timelines[0]
        base_dir = args.motion_dir
        if base_dir is None and args.timeline != "-":
            base_dir = Path(args.timeline).resolve().parent
        options = ExportOptions(
            face_library=args.face_library,
            head_library=args.head_library,
            lexicon=tuple(args.lexicon),
            motion_base_dir=base_dir,
        )
        video = video_options(args)
        notes: tuple[str, ...] = ()
        if args.frames is not None:
            notes = write_frames(timeline, args.frames, options, video).notes
        if args.output is not None and fmt == "png":
            import io

            image, report = render_still(timeline, args.at, options, video)
            buffer = io.BytesIO()
            image.save(buffer, format="PNG")
            write_atomic(args.output, buffer.getvalue())
            notes = notes or report.notes
        elif args.output is not None and fmt is not None:
            notes = notes or write_video(timeline, args.output, fmt, options, video).notes
    except MseError as error:
        return print_error(error)
    except OSError as error:
        target = str(args.output or args.frames)
        reason = error.strerror or str(error)
        print(Diagnostic("E100", f"cannot write output: {reason}", Span(target)).render(), file=sys.stderr)
        return 1
    print_notes(notes, where)
    return 0

"""Where ``mse sample``'s timelines go (cmd_sample.py decides what to sample): stdout or a file
written atomically and flushed as timelines come, one file per timeline in a folder, a video,
or an export format rendered with its notes.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import sys
import time
from collections.abc import Iterable, Iterator
from typing import Any

from mse.cli.common import print_diagnostics
from mse.diagnostics import Diagnostic, MseError, Span, argument_error


class Output:
    """Where streamed output goes: stdout, or a file written atomically (a temporary file
    that takes the output's place when everything is written).  The first write is flushed at
    once, later ones every FLUSH_EVERY seconds, so that a reader sees the first timeline
    without waiting for the rest."""

    FLUSH_EVERY = 0.2

    def __init__(self, handle: Any) -> None:
        self.handle = handle
        self.flushed = 0.0

    def write(self, text: str) -> None:
        self.handle.write(text)
        now = time.monotonic()
        if now - self.flushed >= self.FLUSH_EVERY:
            self.handle.flush()
            self.flushed = now


@contextlib.contextmanager
def output_to(path: str | None, inputs: Iterable[str]) -> Iterator[Output]:
    if path and path != "-":
        from mse.fileio import atomic_path

        with atomic_path(path, inputs=inputs) as temporary, open(temporary, "w", encoding="utf-8") as handle:
            yield Output(handle)
        return
    try:
        yield Output(sys.stdout)
        sys.stdout.flush()
    except BrokenPipeError:
        # The reader went away (``| head``): stop quietly, and let no later flush complain.
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        raise


def write_many(timelines: Iterable[Any], fmt: str, out: Output) -> None:
    """``--count`` output written timeline by timeline (the same text as rendering them all)."""
    for index, timeline in enumerate(timelines):
        if fmt == "jsonl":
            out.write(timeline.dumps(indent=None) + "\n")
        elif fmt == "json":
            item = json.dumps(timeline.to_json(), indent=2, ensure_ascii=False).replace("\n", "\n  ")
            out.write(("[\n  " if index == 0 else ",\n  ") + item)
        else:
            from mse.cli.table import render_table

            out.write(("" if index == 0 else "\n") + render_table(timeline))
    if fmt == "json":
        out.write("\n]\n")


def is_folder(output: str) -> bool:
    from pathlib import Path

    return output.endswith(("/", "\\")) or Path(output).is_dir()


def write_folder(timelines: list[Any], fmt: str, args: argparse.Namespace) -> int:
    """One file per timeline, ``<expression>-<n><suffix>`` (n from 1); all rendered first."""
    from pathlib import Path

    from mse.cli.cmd_export import report_unmapped_faces
    from mse.export import SUFFIXES, export_notes, render
    from mse.fileio import write_atomic

    options = export_options(args)
    report_unmapped_faces(timelines, options, fmt)
    pages = [render(t, fmt, options) for t in timelines]
    for timeline in timelines:
        print_diagnostics(export_notes(timeline, fmt, options, where=args.source or "<sample>"))
    for number, (timeline, page) in enumerate(zip(timelines, pages, strict=True), 1):
        target = Path(args.output) / f"{timeline.expression or 'timeline'}-{number}{SUFFIXES[fmt]}"
        write_atomic(target, page, inputs=[p for p in (args.source, args.library, args.face_library) if p])
    return 0


def write_video_file(timelines: list[Any], fmt: str, args: argparse.Namespace) -> int:
    from pathlib import Path

    from mse.cli.cmd_render import print_notes, video_options
    from mse.export.video import write_video

    if not args.output or args.output == "-" or len(timelines) > 1:
        message = f"--format {fmt} writes one timeline to a file: give -o FILE, no --count"
        raise argument_error(message)
    where = args.source or timelines[0].expression or "<sample>"
    try:
        report = write_video(timelines[0], Path(args.output), fmt, export_options(args), video_options(args))
    except OSError as error:
        reason = error.strerror or str(error)
        raise MseError([Diagnostic("E100", f"cannot write output: {reason}", Span(args.output))]) from None
    print_notes(report.notes, where)
    return 0


def write_binary_file(timelines: list[Any], fmt: str, args: argparse.Namespace) -> int:
    """One timeline in a binary export format (``vrma``) to ``-o FILE``, written atomically."""
    from mse.export import render_bytes
    from mse.fileio import write_atomic

    if not args.output or args.output == "-" or is_folder(args.output) or len(timelines) > 1:
        raise argument_error(f"--format {fmt} writes one timeline to a file: give -o FILE, no --count")
    data = render_bytes(timelines[0], fmt, export_options(args))
    write_atomic(args.output, data, inputs=[p for p in (args.source, args.face_library) if p and p != "-"])
    return 0


def export_options(args: argparse.Namespace) -> Any:
    from pathlib import Path

    from mse.export import ExportOptions

    return ExportOptions(
        character_id=args.character_id,
        face_library=Path(args.face_library) if args.face_library else None,
        bml_extensions=args.bml_extensions,
        motion_base_dir=Path(args.animate) if args.animate else None,
        realizer=args.realizer,
        library_dir=Path(args.library_dir) if args.library_dir else None,
        head_library=args.head_library,
        lexicon=tuple(args.lexicon),
        composition=getattr(args, "composition", "MERGE"),
        block_id=getattr(args, "bml_id", None),
    )


def render_timelines(timelines: list[Any], fmt: str, args: argparse.Namespace, *, many: bool) -> str:
    from mse.timeline import dumps_jsonl

    if fmt == "table":
        from mse.cli.table import render_table

        return "\n".join(render_table(t) for t in timelines)
    if fmt == "jsonl":
        return dumps_jsonl(timelines)
    if fmt == "json":
        if many:
            return json.dumps([t.to_json() for t in timelines], indent=2, ensure_ascii=False) + "\n"
        return str(timelines[0].dumps()) + "\n"
    from mse.export import export_notes, render

    options = export_options(args)
    if len(timelines) > 1:
        raise argument_error(f"--format {fmt} exports one timeline; drop --count or give -o FOLDER/")
    from mse.cli.cmd_export import report_unmapped_faces

    report_unmapped_faces(timelines, options, fmt)
    text = str(render(timelines[0], fmt, options))
    print_diagnostics(export_notes(timelines[0], fmt, options, where=args.source or "<sample>"))
    return text

"""``mse export``: a saved timeline out as BML 1.0, Greta BML, SVG or an HTML viewer.

A file holding several timelines (a JSON array or JSON lines) exports its first one, or
all of them when ``-o`` names a folder (``<stem>-<n>.<suffix>``, n from 1).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mse.cli.cmd_render import add_bml_block_arguments, add_face_arguments
from mse.export import BINARY_FORMATS, FORMAT_NAMES, VIDEO_FORMATS  # light: the exporters themselves load lazily

if TYPE_CHECKING:
    from mse.export import ExportOptions
    from mse.timeline import Timeline


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = subparsers.add_parser(
        "export",
        help="write a saved timeline as BML, Greta BML, SVG, HTML, ELAN (eaf) or video",
        description="Write a timeline (mse-timeline/1 JSON) in another format.",
    )
    p.add_argument("timeline", help="timeline JSON file ('-' reads standard input)")
    p.add_argument(
        "--format",
        "-f",
        choices=FORMAT_NAMES + BINARY_FORMATS + VIDEO_FORMATS,
        help="output format (default: from the -o file's extension, e.g. t.svg -> svg, t.bml -> bml)",
    )
    p.add_argument(
        "-o",
        "--output",
        help="output file (default: standard output); an existing folder or a path ending "
        "in '/' receives every timeline of the input",
    )
    p.add_argument("--face-library", type=Path, help="Greta facelibrary.xml for face lexemes")
    p.add_argument(
        "--bml-extensions",
        action="store_true",
        help="allow BML extensions (ext:faceFacs per action unit); leaves the BML 1.0 schema",
    )
    p.add_argument(
        "--bml-constraints",
        action="store_true",
        help="add <constraint> metadata for sync points that share a time",
    )
    p.add_argument("--character-id", default="Agent", help="BML characterId (default: Agent)")
    add_face_arguments(p)
    add_bml_block_arguments(p)
    p.add_argument(
        "--realizer",
        choices=("generic", "greta", "asap"),
        help="BML for this realizer (default: generic for bml, greta for greta-bml)",
    )
    p.add_argument("--library-dir", type=Path, help="the realizer's libraries (Greta's BehaviorLexicon folder)")
    p.add_argument(
        "--motion-dir",
        type=Path,
        help="folder that motion file paths are relative to (default: the timeline's folder)",
    )
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from mse.cli.common import read_timelines
    from mse.diagnostics import Diagnostic, MseError, Span
    from mse.export import SUFFIXES, ExportOptions, export_notes, render, render_bytes
    from mse.fileio import write_atomic

    output: str | None = args.output
    try:
        args.format = args.format or _format_from_output(output)
        where = "<stdin>" if args.timeline == "-" else args.timeline
        timelines = read_timelines(args.timeline)
        if not timelines:
            raise MseError([Diagnostic("E212", "no timeline in the input", Span(where))])
        base_dir = args.motion_dir
        if base_dir is None and args.timeline != "-":
            base_dir = Path(args.timeline).resolve().parent
        options = ExportOptions(
            character_id=args.character_id,
            face_library=args.face_library,
            bml_extensions=args.bml_extensions,
            bml_constraints=args.bml_constraints,
            motion_base_dir=base_dir,
            realizer=args.realizer,
            library_dir=args.library_dir,
            head_library=args.head_library,
            lexicon=tuple(args.lexicon),
            composition=args.composition,
            block_id=args.bml_id,
        )
        to_folder = output is not None and (output.endswith(("/", "\\")) or Path(output).is_dir())
        if not to_folder:
            if len(timelines) > 1:
                print(
                    f"{where}: note: {len(timelines)} timelines, exported the first (give -o FOLDER/ to export all)",
                    file=sys.stderr,
                )
            timelines = timelines[:1]
        if args.format in VIDEO_FORMATS:
            return _videos(timelines, args.format, output, to_folder, where, options)
        # Render everything before writing anything: bad input leaves no partial output.
        binary = args.format in BINARY_FORMATS
        pages: list[str | bytes] = [
            render_bytes(t, args.format, options) if binary else render(t, args.format, options) for t in timelines
        ]
        notes = [note for t in timelines for note in export_notes(t, args.format, options, where)]
    except MseError as error:
        for diagnostic in error.diagnostics:
            print(diagnostic.render(), file=sys.stderr)
        return 1
    report_unmapped_faces(timelines, options, args.format)
    for note in notes:
        print(note.render(), file=sys.stderr)
    if output is None:
        page = pages[0]
        if isinstance(page, bytes):
            sys.stdout.buffer.write(page)
        else:
            sys.stdout.write(page)
        return 0
    stem = Path(where).stem if where != "<stdin>" else "timeline"
    targets = (
        [Path(output) / f"{stem}-{n}{SUFFIXES[args.format]}" for n in range(1, len(pages) + 1)]
        if to_folder
        else [Path(output)]
    )
    inputs = [p for p in (args.timeline, args.face_library) if p]
    for target, page in zip(targets, pages, strict=True):
        try:
            write_atomic(target, page, inputs=inputs)
        except MseError as error:
            for diagnostic in error.diagnostics:
                print(diagnostic.render(), file=sys.stderr)
            return 1
    return 0


def _format_from_output(output: str | None) -> str:
    """The export format named by the output file's extension (``t.svg`` -> svg)."""
    from mse.diagnostics import argument_error
    from mse.export import SUFFIXES

    by_suffix = {suffix: name for name, suffix in SUFFIXES.items()}
    by_suffix.setdefault(".htm", "html")
    suffix = Path(output).suffix.lower() if output else ""
    if output and "".join(Path(output).suffixes[-2:]).lower() in by_suffix:  # t.arkit.csv
        suffix = "".join(Path(output).suffixes[-2:]).lower()
    if output and not output.endswith(("/", "\\")) and suffix in by_suffix:
        return by_suffix[suffix]
    known = ", ".join(f"{s} ({n})" for s, n in by_suffix.items())
    what = f"from {output!r}" if output else "without -o"
    message = f"cannot tell the format {what}: give --format, or -o a file ending in {known}"
    raise argument_error(message)


def report_unmapped_faces(timelines: list[Timeline], options: ExportOptions, fmt: str | None = None) -> None:
    """With --face-library, say which face lexemes the library lacks: they are exported as
    plain lexemes, without action units, which --bml-extensions would otherwise add.  For the
    greta profile a face is looked up by the Greta name it is written with."""
    from mse.export.lexemes import Lexeme, modality_of, split_lexeme
    from mse.export.realizer_libraries import load_face_library
    from mse.export.realizers import realize_greta, realizer_for

    if options.face_library is None:
        return
    library = load_face_library(options.face_library)
    greta = fmt in ("bml", "greta-bml") and realizer_for(fmt, options.realizer) == "greta"

    def looked_up(lexeme: Lexeme) -> Lexeme:
        return Lexeme("faceexp", realize_greta("face", lexeme, None).name) if greta else lexeme

    missing = sorted(
        {
            s.lexeme
            for timeline in timelines
            for s in timeline.signals
            for lexeme in (split_lexeme(s.lexeme),)
            if modality_of(s.modality, lexeme) == "face" and library.resolve(looked_up(lexeme)) is None
        }
    )
    if missing:
        effect = "as plain faceLexeme, without ext:faceFacs" if options.bml_extensions else "without action units"
        print(
            f"{options.face_library}: warning: face lexeme(s) not in this face library, exported {effect}: "
            f"{', '.join(missing)}",
            file=sys.stderr,
        )


def _videos(timelines: list[Any], fmt: str, output: str | None, to_folder: bool, where: str, options: Any) -> int:
    """Video formats are written by ``mse.export.video`` straight to their files."""
    from mse.cli.cmd_render import print_notes
    from mse.diagnostics import Diagnostic, Span, argument_error
    from mse.export import SUFFIXES
    from mse.export.video import write_video

    if output is None:
        raise argument_error(f"--format {fmt} writes a file: give -o FILE")
    stem = Path(where).stem if where != "<stdin>" else "timeline"
    targets = (
        [Path(output) / f"{stem}-{n}{SUFFIXES[fmt]}" for n in range(1, len(timelines) + 1)]
        if to_folder
        else [Path(output)]
    )
    notes: list[str] = []
    for target, timeline in zip(targets, timelines, strict=True):
        try:
            report = write_video(timeline, target, fmt, options)
        except OSError as error:
            reason = error.strerror or str(error)
            print(Diagnostic("E100", f"cannot write output: {reason}", Span(str(target))).render(), file=sys.stderr)
            return 1
        notes += [note for note in report.notes if note not in notes]
    print_notes(notes, where)
    return 0

"""``mse live SCRIPT``: a dialogue script (JSON Lines of emotion changes, utterances and its end,
or an FML-APML or EmotionML file) planned episode by episode into one multi-episode timeline
(docs/dialogue.md, docs/dialogue-inputs.md)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from mse.cli.common import add_quiet, emit, print_error
from mse.diagnostics import MseError, argument_error

FORMATS = ("json", "table", "bml", "greta-bml", "svg", "html", "eaf", "openface", "arkit", "arkit-json", "vrma",
           "mp4", "webm", "gif")
REALIZERS = ("generic", "greta", "asap")


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "live",
        help="plan a dialogue script (emotion changes, utterances) into one multi-episode timeline",
        description="Read a dialogue script (JSON Lines: {\"t\": 0, \"emotion\": \"anger\", \"until\": 3.7}, "
        "{\"t\": 0.4, \"say\": \"...\"}, {\"t\": 8.7, \"end\": true}) and plan each episode as it comes into "
        "one timeline; --format gives every export of the whole dialogue. Exit 1 on bad input (nothing written).",
    )
    parser.add_argument("script", help="dialogue script: JSON Lines ('-' for stdin), FML-APML or EmotionML")
    parser.add_argument("-o", "--output", help="write to this file (atomically) instead of stdout")
    parser.add_argument("--format", choices=FORMATS,
                        help="output format (default: from the -o file's extension, else json)")
    parser.add_argument("--seed", type=int, help="random seed (default: fresh; recorded in the output)")
    parser.add_argument("--horizon", type=float, default=10.0,
                        help="seconds planned at once for an episode whose end is not announced (default 10)")
    add_quiet(parser)
    out = parser.add_argument_group("export")
    out.add_argument("--face-library", metavar="FILE", help="Greta face library for FACS export")
    out.add_argument("--bml-extensions", action="store_true", help="BML: faces as FACS action units")
    out.add_argument("--character-id", default="Agent", help="BML characterId (default Agent)")
    out.add_argument("--realizer", choices=REALIZERS, help="BML for this realizer (default: generic for bml, "
                     "greta for greta-bml)")
    out.add_argument("--library-dir", metavar="DIR", help="the realizer's libraries (Greta's BehaviorLexicon folder)")
    from mse.cli.cmd_render import add_bml_block_arguments, add_face_arguments, add_video_arguments

    add_face_arguments(out)
    add_bml_block_arguments(out)
    add_video_arguments(parser.add_argument_group("video (--format mp4, webm, gif: as mse render)"))
    parser.set_defaults(handler=run)


def _format(args: argparse.Namespace) -> str:
    from mse.cli.output_format import output_format

    return output_format(args.format, args.output, FORMATS) or "json"


def run(args: argparse.Namespace) -> int:
    import random

    from mse.cli.common import print_diagnostics
    from mse.cli.sample_output import render_timelines, write_binary_file, write_video_file
    from mse.dialogue import plan_script
    from mse.dialogue.inputs import read_events
    from mse.limits import solve_duration_problem

    try:
        fmt = _format(args)
        problem = solve_duration_problem(args.horizon)
        if problem is not None:
            raise argument_error(f"--horizon {problem}")
        events, notes = read_events(args.script)
        print_diagnostics(notes)  # what the input holds that mse cannot use, never dropped silently
        seed = args.seed if args.seed is not None else random.SystemRandom().randrange(2**31)
        base = None if args.script == "-" else Path(args.script).resolve().parent
        timeline = plan_script(events, seed=seed, horizon=args.horizon, base=base)
        args.source, args.animate, args.library = (None if args.script == "-" else args.script), None, None
        if fmt in ("mp4", "webm", "gif"):
            return write_video_file([timeline], fmt, args)
        if fmt == "vrma":
            return write_binary_file([timeline], fmt, args)
        text = render_timelines([timeline], fmt, args, many=False)
        emit(text, args.output, inputs=[p for p in (args.script, args.face_library) if p and p != "-"])
    except MseError as error:
        return print_error(error)
    return 0




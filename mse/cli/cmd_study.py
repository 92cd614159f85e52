"""``mse study``: perception studies of MSE stimuli (docs/study.md).

``mse study make --emotions anger,relief -o DIR`` builds the stimuli, the counterbalanced
orders and the page; ``mse study serve DIR`` serves the page and stores the answers;
``mse study analyze RESULTS...`` reports their statistics (docs/study-analysis.md).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from mse.cli import study_analyze
from mse.cli.common import add_quiet


def _emotions(text: str) -> list[str]:
    names = [part.strip() for part in text.split(",")]
    if not text.strip() or any(not name for name in names):
        raise argparse.ArgumentTypeError(f"{text!r} is not a comma-separated list of emotions (e.g. anger,relief)")
    return names


def register(subparsers: Any) -> None:
    from mse.cli.cmd_render import _size

    p = subparsers.add_parser(
        "study",
        help="perception studies: make the stimuli and a study page, serve it, collect and analyse the answers",
        description="Perception studies of MSE stimuli: 'make' builds a study folder, "
        "'serve' serves its page and stores each participant's answers as CSV, 'analyze' reports their "
        "statistics.",
    )
    commands = p.add_subparsers(dest="study_command", metavar="SUBCOMMAND")
    make = commands.add_parser(
        "make",
        help="build a study folder: stimuli per condition, counterbalanced orders, manifest, page",
        description="Build a study folder: for each emotion, stimuli in the conditions mse (sampled with the "
        "constraints), control (constraint-less), image (a still at the apex) and optionally face (face-only), "
        "every participant's order (balanced Latin squares), a manifest with the command of every stimulus, "
        "and the study page. Needs the 'video' extra.",
    )
    make.add_argument("--emotions", type=_emotions, required=True, metavar="A,B,...",
                      help="bundled behaviour-set names or paths to behaviour sets, comma-separated")
    make.add_argument("-o", "--output", type=Path, required=True, metavar="DIR", help="the study folder (new or empty)")
    make.add_argument("--participants", type=int, default=8, metavar="N",
                      help="number of participants planned (ids p01 ...; default 8)")
    make.add_argument("--seed", type=int, help="seed of the study (default: fresh; recorded in the manifest)")
    make.add_argument("-d", "--duration", type=float, default=4.0, help="length of every stimulus in seconds "
                      "(default 4)")
    make.add_argument("--face-only", action="store_true", help="add the face condition: the MSE stimulus' face, "
                      "gaze and head signals alone")
    make.add_argument("--stimuli-per-condition", type=int, default=1, metavar="K",
                      help="stimuli per emotion and condition (default 1)")
    make.add_argument("--size", type=_size, default=(640, 720), metavar="WxH",
                      help="frame size (default 640x720: the half body down to the hips)")
    make.add_argument("--fps", type=float, default=25.0, help="frames per second (default 25)")
    make.add_argument("--force", action="store_true", help="replace DIR when it holds a study made before")
    add_quiet(make)
    make.set_defaults(handler=run_make)
    serve = commands.add_parser(
        "serve",
        help="serve a study folder's page; store each participant's answers in DIR/results/",
        description="Serve a study folder over HTTP (until Ctrl-C). The page POSTs each participant's answers, "
        "stored as DIR/results/<participant>.csv.",
    )
    serve.add_argument("folder", type=Path, metavar="DIR", help="a folder made by mse study make")
    serve.add_argument("--port", type=int, default=8000, help="TCP port (default 8000; 0: any free port)")
    serve.add_argument("--host", default="127.0.0.1",
                       help="address to listen on (default 127.0.0.1; 0.0.0.0 for other machines)")
    serve.set_defaults(handler=run_serve)
    study_analyze.register(commands)
    p.set_defaults(handler=lambda _args: _usage(p))


def _usage(parser: argparse.ArgumentParser) -> int:
    parser.print_help(sys.stderr)
    return 2


def run_mse(argv: Sequence[str]) -> tuple[int, str]:
    """One ``mse`` command in this process; its standard error is captured and returned."""
    import contextlib
    import io

    from mse.cli import main

    errors = io.StringIO()
    with contextlib.redirect_stderr(errors):
        code = main(list(argv))
    return code, errors.getvalue()


def run_make(args: argparse.Namespace) -> int:
    import math
    import random
    import time

    from mse.cli.common import print_error
    from mse.diagnostics import MseError, argument_error
    from mse.extras import require
    from mse.limits import solve_duration_problem
    from mse.study.design import Settings
    from mse.study.make import make_study

    try:
        problems = []
        duration_problem = solve_duration_problem(args.duration)
        if duration_problem is not None:
            problems.append(f"--duration {duration_problem}")
        elif args.duration > 600:
            problems.append("--duration: a stimulus of at most 600 s")
        if not 1 <= args.participants <= 10_000:
            problems.append("--participants must be between 1 and 10000")
        if not 1 <= args.stimuli_per_condition <= 100:
            problems.append("--stimuli-per-condition must be between 1 and 100")
        if not (math.isfinite(args.fps) and 1 <= args.fps <= 120):
            problems.append("--fps must be between 1 and 120")
        if args.size[0] % 2 or args.size[1] % 2:
            problems.append(f"--size {args.size[0]}x{args.size[1]}: WebM needs even numbers")
        if problems:
            raise argument_error(*problems)
        with require("video"):  # said at once, before any stimulus is made
            import av  # noqa: F401
            import PIL  # noqa: F401
        seed = args.seed if args.seed is not None else random.SystemRandom().randrange(2**31)
        settings = Settings(duration=args.duration, seed=seed, participants=args.participants,
                            per_condition=args.stimuli_per_condition, face_only=args.face_only,
                            size=args.size, fps=args.fps)
        command = ["mse", "study", "make", "--emotions", ",".join(args.emotions), "-o", str(args.output),
                   "--participants", str(args.participants), "--seed", str(seed), "-d", f"{args.duration:g}",
                   "--stimuli-per-condition", str(args.stimuli_per_condition),
                   "--size", f"{args.size[0]}x{args.size[1]}", "--fps", f"{args.fps:g}"]
        if args.face_only:
            command.append("--face-only")
        began = time.monotonic()
        manifest = make_study(args.emotions, args.output, settings, run_mse, force=args.force, command=command)
    except MseError as error:
        return print_error(error)
    if not args.quiet:
        print(f"{args.output}: {len(manifest['stimuli'])} stimuli, {len(manifest['participants'])} participants, "
              f"seed {seed} ({time.monotonic() - began:.1f} s); serve it with: mse study serve {args.output}",
              file=sys.stderr)
    return 0


def run_serve(args: argparse.Namespace) -> int:
    from mse.cli.common import print_error
    from mse.diagnostics import Diagnostic, MseError, Span, argument_error
    from mse.study.make import read_manifest
    from mse.study.server import make_server

    try:
        if not 0 <= args.port <= 65535:
            raise argument_error(f"--port {args.port} must be between 0 and 65535")
        manifest = read_manifest(args.folder)
        try:
            server = make_server(args.folder.resolve(), manifest, args.host, args.port)
        except OSError as error:
            message = f"cannot listen on {args.host}:{args.port}: {error.strerror or error}"
            raise MseError([Diagnostic("E100", message, Span(str(args.folder)))]) from None
    except MseError as error:
        return print_error(error)
    host, port = str(server.server_address[0]), int(server.server_address[1])
    shown = "127.0.0.1" if host in ("0.0.0.0", "") else host
    print(f"serving {args.folder} at http://{shown}:{port}/ (Ctrl-C to stop)", flush=True)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        server.server_close()
    return 0

"""``mse sample [SOURCE]``: timelines from a behaviour set (greedy, cpsat or csp solver)."""

from __future__ import annotations

import argparse
import json
import os
import re
import stat
import sys
import time
from typing import Any

from mse.cli.common import add_quiet, emit, print_diagnostics, print_error, read_stdin_bytes
from mse.diagnostics import Diagnostic, MseError, Span, argument_error
from mse.limits import MAX_SECONDS, solve_duration_problem
from mse.solve.objectives import DEFAULT_OBJECTIVE, OBJECTIVES

BASE_FORMATS = ("table", "json", "jsonl")
EXPORT_FORMATS = ("bml", "greta-bml", "svg", "html", "eaf", "openface", "arkit", "arkit-json")
REALIZERS = ("generic", "greta", "asap")  # mse.export.realizers.REALIZERS (not imported: start-up time)
VIDEO_FORMATS = ("mp4", "webm", "gif")
BINARY_FORMATS = ("vrma",)
SAMPLE_FORMATS = BASE_FORMATS + EXPORT_FORMATS + BINARY_FORMATS + VIDEO_FORMATS
_PIN = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)@([0-9]{1,12}(?:\.[0-9]{1,12})?)-([0-9]{1,12}(?:\.[0-9]{1,12})?)")


def _names(value: str) -> list[str]:
    return [part.strip() for part in value.split(",") if part.strip()]


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "sample",
        help="produce timelines (default: the bundled embarrassment, 10 s)",
        description="Produce timelines consistent with a behaviour set. SOURCE is a file, a bundled "
        "name, '-' or piped compiled IR (mse compile x.xml | mse sample). Exit 1 on bad input, "
        "2 when no timeline exists.",
    )
    parser.add_argument("source", nargs="?", help="behaviour-set file, bundled name, or '-' for stdin")
    add_quiet(parser)
    parser.add_argument("-d", "--duration", type=float, default=10.0, help="timeline length in seconds (default 10)")
    parser.add_argument("--seed", type=int, help="random seed (default: fresh; recorded in the output)")
    parser.add_argument("-n", "--count", type=int, help="number of timelines (seeds seed, seed+1, ...)")
    parser.add_argument(
        "--format", choices=SAMPLE_FORMATS,
        help="table on a terminal, else json; without it, -o's suffix decides (.json .jsonl .bml .svg .html .eaf .mp4 "
        ".webm .gif)"
    )
    parser.add_argument("-o", "--output", help="write to this file (atomically) instead of stdout; with --count and "
                        "an export format, a folder (ending in '/') receives one file per timeline")
    parser.add_argument(
        "--solver",
        choices=("greedy", "cpsat", "csp"),
        default="greedy",
        help="greedy: the paper's stochastic sampler (default); cpsat: exact (OR-Tools CP-SAT); "
        "csp: exhaustive grid search, an oracle for small sets",
    )
    parser.add_argument(
        "--mode",
        choices=("consistent", "constraint-less"),
        default="consistent",
        help="consistent (default) or constraint-less: ignore the constraints, the paper's control condition",
    )
    parser.add_argument("--stream", action="store_true", help="print each signal as a JSON line once decided")
    parser.add_argument("--speech", metavar="FILE",
                        help="the agent's speech (JSON: start, stop, words, stress) for speech.start, "
                        "speech.stop and stressed in constraints")
    parser.add_argument("--realtime", action="store_true", help="with --stream: pace the lines to the clock")
    parser.add_argument("--slot", type=float, help="greedy: time-stamp length in seconds (default about 1)")
    parser.add_argument("--max-restarts", type=int, default=20,
                        help="greedy: backtracks without progress before the CP-SAT fallback (default 20)")
    wanted = parser.add_argument_group("requests", "A solver that cannot honour a request refuses it and says so.")
    pin_help = "SIG occurs from START to STOP seconds (repeatable)"
    wanted.add_argument("--pin", action="append", default=[], metavar="SIG@START-STOP", help=pin_help)
    require_help, forbid_help = "SIG must occur (repeatable, or a,b)", "SIG must not occur (repeatable, or a,b)"
    wanted.add_argument("--require", action="append", type=_names, default=[], metavar="SIG", help=require_help)
    wanted.add_argument("--forbid", action="append", type=_names, default=[], metavar="SIG", help=forbid_help)
    exact = parser.add_argument_group("exact solvers (cpsat, csp)")
    exact.add_argument(
        "--objective",
        choices=(DEFAULT_OBJECTIVE, *OBJECTIVES),
        default=DEFAULT_OBJECTIVE,
        help="cpsat: profile (default) samples the signals' probability profiles; likely: the most probable "
        "timeline; random: ignore the probabilities; most-signals/fewest-signals: as many/few signals as possible",
    )
    exact.add_argument("--diverse", action="store_true", help="with --count: maximally different timelines")
    exact.add_argument("--time-limit", type=float, default=10.0,
                       help="seconds per timeline, and per window of the rolling horizon of a long one (default 10)")
    exact.add_argument("--workers", type=int, default=1, help="CP-SAT search workers (default 1: reproducible)")
    exact.add_argument("--grid", type=float, default=0.5, help="csp: grid step in seconds (default 0.5)")
    out = parser.add_argument_group("motion and export")
    out.add_argument("--animate", metavar="DIR", help="generate motion for every motion leaf into DIR")
    out.add_argument("--library", metavar="DIR", help="motion library (default: the starter library)")
    out.add_argument("--face-library", metavar="FILE", help="Greta face library for FACS export")
    out.add_argument("--bml-extensions", action="store_true", help="BML: faces as FACS action units")
    out.add_argument("--character-id", default="Agent", help="BML characterId (default Agent)")
    out.add_argument(
        "--realizer",
        choices=REALIZERS,
        help="BML for this realizer (default: generic for bml, greta for greta-bml)",
    )
    out.add_argument("--library-dir", metavar="DIR", help="the realizer's libraries (Greta's BehaviorLexicon folder)")
    from mse.cli.cmd_render import add_bml_block_arguments, add_face_arguments, add_video_arguments

    add_face_arguments(out)
    add_bml_block_arguments(out)
    add_video_arguments(parser.add_argument_group("video (--format mp4, webm, gif: as mse render)"))
    parser.set_defaults(handler=run)


def _stdin_has_data() -> bool:
    try:
        mode = os.fstat(sys.stdin.fileno()).st_mode
    except (OSError, ValueError, AttributeError):
        return False
    return stat.S_ISFIFO(mode) or stat.S_ISREG(mode)


def _stdin_inherited() -> bool:
    """True when our stdin is our parent's own (no pipe was made for this command, as when
    a script run with an empty pipe for input calls ``mse sample``); Linux only."""
    try:
        mine = os.fstat(sys.stdin.fileno())
        parents = os.stat(f"/proc/{os.getppid()}/fd/0")
    except (OSError, ValueError, AttributeError):
        return False
    return (mine.st_dev, mine.st_ino) == (parents.st_dev, parents.st_ino)


def _inherited_and_silent(wait: float = 0.2) -> bool:
    """Our parent's own stdin that brings nothing at once (a harness's pipe left open): not
    input for us.  Reading it would block forever when its writer never closes it."""
    if not _stdin_inherited():
        return False
    import select

    try:
        ready, _, _ = select.select([sys.stdin.fileno()], [], [], wait)
    except (OSError, ValueError):
        return False
    return not ready


def load_model_argument(source: str | None) -> Any:
    """The model named by SOURCE; piped input; or the bundled default (said on stderr)."""
    from mse.api import load, loads
    from mse.resources import DEFAULT_EXPRESSION

    if source is not None and source != "-":
        return load(source, cache=True)
    if source == "-" or (_stdin_has_data() and not _inherited_and_silent()):
        data = read_stdin_bytes()
        if not data.strip() and (source == "-" or not _stdin_inherited()):
            # An empty pipe made for us is a failed producer (mse compile bad.xml | mse
            # sample), not a request for the bundled default.
            message = (
                "no model on stdin (the input was empty: did the command before the pipe fail?); "
                f"name a SOURCE, e.g. 'mse sample {DEFAULT_EXPRESSION}'"
            )
            raise MseError([Diagnostic("E100", message, Span("<stdin>"))])
        if data.strip():
            return loads(data, path="<stdin>")
    print(f"mse: sampling the bundled expression '{DEFAULT_EXPRESSION}'", file=sys.stderr)
    return load(DEFAULT_EXPRESSION, cache=True)


def _pins(values: list[str]) -> tuple[Any, ...]:
    from mse.solve.protocol import Pin

    pins = []
    for value in values:
        match = _PIN.fullmatch(value)
        if not match:
            raise argument_error(f"--pin {value!r} must look like SIGNAL@START-STOP, e.g. smile@4.0-6.0")
        start, stop = float(match.group(2)), float(match.group(3))
        if not (start <= MAX_SECONDS and stop <= MAX_SECONDS):
            message = f"--pin {value!r}: times must be at most {MAX_SECONDS:g} s"
            raise MseError([Diagnostic("E215", message, Span("<arguments>"))])
        pins.append(Pin(match.group(1), start, stop))
    return tuple(pins)


def _options(args: argparse.Namespace) -> dict[str, Any]:
    """The keyword options of :func:`mse.sampling.sample` (its ``SampleOptions``)."""
    from mse.solve.protocol import CpSatOptions, CspOptions, GreedyOptions

    return {
        "time_limit": args.time_limit,
        "diverse": args.diverse,
        "pinned": _pins(args.pin),
        "require": tuple(n for group in args.require for n in group),
        "forbid": tuple(n for group in args.forbid for n in group),
        "objective": args.objective,
        "greedy": GreedyOptions(slot=args.slot, max_restarts=args.max_restarts),
        "cpsat": CpSatOptions(workers=args.workers),
        "csp": CspOptions(grid=args.grid),
    }


def _validate(args: argparse.Namespace) -> None:
    problems = []
    for option, value in (("--duration", args.duration), ("--slot", args.slot)):
        problem = solve_duration_problem(value) if value is not None else None
        if problem is not None:
            problems.append(f"{option} {problem}")
    if not 0 < args.time_limit <= 86400 or not 0 < args.grid <= 3600:
        problems.append("--time-limit must be in (0, 86400] s and --grid in (0, 3600] s")
    if args.count is not None and not 1 <= args.count <= 1_000_000:
        problems.append("--count must be between 1 and 1000000")
    if args.realtime and not args.stream:
        problems.append("--realtime goes with --stream")
    if args.stream and args.format not in (None, "jsonl", "json"):
        problems.append("--stream prints JSON lines; drop --format")
    if problems:
        raise argument_error(*problems)
    from mse.cli.output_format import output_format

    # before any solving: -o's suffix must agree with what is written (--stream writes JSON lines)
    output_format(args.format, args.output, ("json", "jsonl") if args.stream else SAMPLE_FORMATS)


def run(args: argparse.Namespace) -> int:
    from mse.solve.protocol import NoSolution

    try:
        _validate(args)
        from mse.ir.anchors import read_speech, resolve_anchors

        model = load_model_argument(args.source)
        model = resolve_anchors(model, read_speech(args.speech) if args.speech else None)
        if args.stream:
            return _stream(model, args)
        return _sample(model, args)
    except NoSolution as error:
        print_diagnostics(error.diagnostics)
        return 2
    except MseError as error:
        return print_error(error)


def _seed(args: argparse.Namespace) -> int:
    """The seed of the run: given, or fresh (and recorded in the output)."""
    if args.seed is not None:
        return int(args.seed)
    import random

    return random.SystemRandom().randrange(2**31)


def _stream(model: Any, args: argparse.Namespace) -> int:
    """JSON lines, one per occurrence as soon as it is decided; each line names the expression,
    the seed and the duration of its timeline (``--count``: timelines one after another)."""
    from mse.cli.sample_output import output_to
    from mse.sampling import iter_sample
    from mse.solve.protocol import derive_seed

    seed = _seed(args)
    with output_to(args.output, [p for p in (args.source,) if p]) as out:
        for index in range(args.count or 1):
            began = time.monotonic()
            timeline_seed = derive_seed(seed, index)
            for signal in iter_sample(
                model, args.duration, seed=timeline_seed, solver=args.solver, mode=args.mode, **_options(args)
            ):
                if args.realtime:
                    delay = signal.start - (time.monotonic() - began)
                    if delay > 0:
                        time.sleep(delay)
                line = {**signal.to_json(), "expression": model.name, "seed": timeline_seed,
                        "duration": args.duration}
                out.write(json.dumps(line, ensure_ascii=False) + "\n")
    return 0


def _sample(model: Any, args: argparse.Namespace) -> int:
    from mse.cli.output_format import output_format
    from mse.cli.sample_output import (
        is_folder,
        output_to,
        render_timelines,
        write_binary_file,
        write_folder,
        write_many,
        write_video_file,
    )
    from mse.sampling import iter_timelines

    given = output_format(args.format, args.output, SAMPLE_FORMATS)
    fmt = given or ("table" if sys.stdout.isatty() and not args.output else "json")
    if args.count is not None and not args.animate and fmt in BASE_FORMATS:
        timelines_stream = iter_timelines(model, args.duration, seed=args.seed, count=args.count,
                                          solver=args.solver, mode=args.mode, **_options(args))
        with output_to(args.output, [p for p in (args.source,) if p]) as out:
            write_many(timelines_stream, fmt, out)
        return 0
    timelines = list(iter_timelines(model, args.duration, seed=args.seed, count=args.count or 1,
                                    solver=args.solver, mode=args.mode, **_options(args)))
    if args.animate:
        from pathlib import Path

        from mse.cli.cmd_animate import animate_timelines

        inputs = [p for p in (args.source, args.library) if p]
        timelines = animate_timelines([(t, model) for t in timelines], Path(args.animate), args.library, inputs=inputs)
    if fmt in VIDEO_FORMATS:
        return write_video_file(timelines, fmt, args)
    if fmt in BINARY_FORMATS:
        return write_binary_file(timelines, fmt, args)
    if fmt in EXPORT_FORMATS and args.output and is_folder(args.output):
        return write_folder(timelines, fmt, args)
    inputs = [p for p in (args.source, args.library, args.face_library) if p]
    emit(render_timelines(timelines, fmt, args, many=args.count is not None), args.output, inputs=inputs)
    return 0



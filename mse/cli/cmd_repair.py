"""``mse repair SET PROPOSAL -o fixed.json``: the consistent timeline nearest to a proposal."""

from __future__ import annotations

import argparse
import math
import sys
from typing import Any

from mse.cli.common import add_quiet, emit, print_diagnostics, print_error
from mse.diagnostics import Diagnostic, MseError, Span


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "repair",
        help="repair a proposed expression into the nearest consistent timeline",
        description="Read a proposal (a timeline JSON, an mse-proposal/1 JSON, or tagged text such as "
        "'[nod] I [smile]really[/smile] mean it') and write the consistent timeline that changes it "
        "least: first the fewest occurrences dropped or added, then the least time moved "
        "(milliseconds, times each occurrence's weight). "
        "Each change is reported on stderr with the rule (file:line) that forced it. Exit 0: repaired or "
        "already consistent (then written back unchanged); 1: bad input; 2: no repair keeps what --keep "
        "demands (with a minimal explanation).",
    )
    parser.add_argument("source", help="a behaviour-set file or a bundled expression name")
    parser.add_argument("proposal", help="the proposal file ('-' for stdin)")
    parser.add_argument("-o", "--output", help="the repaired timeline (default: stdout)")
    parser.add_argument("--keep", action="extend", nargs="+", default=[], metavar="ID",
                        help="signal ids or occurrence ids whose proposed occurrences must not be dropped")
    parser.add_argument("--duration", type=float, default=None,
                        help="timeline length in seconds when the proposal gives none "
                        "(default: where its last occurrence or word ends)")
    parser.add_argument("--report", metavar="PATH", help="also write the report as JSON ('-': stdout)")
    parser.add_argument("--strict", action="store_true",
                        help="an occurrence naming no signal of the set is an error (exit 1), not a warning")
    parser.add_argument("--time-limit", type=float, default=10.0, help="CP-SAT time limit in seconds (default 10)")
    parser.add_argument("--workers", type=int, default=1, help="CP-SAT search workers (default 1: reproducible)")
    add_quiet(parser)
    parser.set_defaults(handler=run)


def _argument_problems(args: argparse.Namespace) -> list[str]:
    from mse.limits import solve_duration_problem

    problems = []
    if args.duration is not None:
        problem = solve_duration_problem(args.duration)
        if problem is not None:
            problems.append(f"--duration {problem}")
    if not (math.isfinite(args.time_limit) and 0 < args.time_limit <= 86400):
        problems.append("--time-limit must be in (0, 86400] s")
    if not 1 <= args.workers <= 64:
        problems.append("--workers must be in [1, 64]")
    if args.report == "-" and (not args.output or args.output == "-"):
        problems.append("--report - and the timeline cannot both go to stdout (give -o)")
    return problems


def run(args: argparse.Namespace) -> int:
    from mse.api import load
    from mse.input_files import decode_utf8, read_input
    from mse.repairing.read import CODE
    from mse.repairing.repair import NoRepair, as_proposal, repair

    problems = _argument_problems(args)
    if problems:
        print_diagnostics(Diagnostic("E100", p, Span("<arguments>")) for p in problems)
        return 1
    where = "<stdin>" if args.proposal == "-" else args.proposal
    try:
        model = load(args.source)
        text = decode_utf8(read_input(args.proposal, what="proposal"), where, code=CODE, what="proposal")
        proposal = as_proposal(model, text, duration=args.duration, path=where)
        if args.strict and proposal.foreign:
            raise MseError([Diagnostic(CODE, f"{o.describe()} names no signal of {model.name!r}", o.span)
                            for o in proposal.foreign])
        result = repair(model, proposal, keep=args.keep, time_limit=args.time_limit, workers=args.workers)
    except NoRepair as failure:
        print_diagnostics(failure.diagnostics)
        return 2
    except MseError as error:
        return print_error(error)
    if result.unchanged and proposal.form == "timeline" and proposal.text is not None:
        output = proposal.text  # a consistent timeline comes back byte for byte
    else:
        output = result.timeline.dumps() + "\n"
    inputs = [args.proposal, args.source]
    try:
        if args.report is not None:
            emit(result.dumps_report() + "\n", args.report, inputs=inputs)
        emit(output, args.output, inputs=inputs)
    except MseError as error:
        return print_error(error)
    if not args.quiet:
        for line in result.render():
            print(line, file=sys.stderr)
    return 0

"""``mse check MODEL TIMELINE``: each violated rule of each timeline, with file:line."""

from __future__ import annotations

import argparse
import json
import sys
from typing import TYPE_CHECKING, Any

from mse.cli.common import print_error, read_timelines
from mse.diagnostics import Diagnostic, MseError, Span

if TYPE_CHECKING:
    from mse.ir.evaluate import Violation


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "check",
        help="check timelines against a behaviour set",
        description="Check one timeline, a JSON array of timelines, or JSON lines against a "
        "behaviour set. Prints each violated constraint with its file:line and a summary line "
        "on stdout (--format json: one report object); exit 1 if any. A dialogue's timeline "
        "(mse live) is checked episode by episode, each against its own set: 'mse check dialogue.json'.",
    )
    parser.add_argument("source", help="a behaviour-set file or a bundled expression name (or, alone, a "
                        "dialogue's timeline)")
    parser.add_argument("timeline", nargs="?", help="timeline JSON file ('-' for stdin)")
    parser.add_argument("-q", "--quiet", action="store_true", help="print nothing when consistent")
    parser.add_argument("--speech", metavar="FILE",
                        help="the agent's speech for speech anchors (default: each timeline's 'utterances')")
    parser.add_argument(
        "--format",
        choices=("text", "json"),
        default="text",
        help="text (default): a line per violation, then a summary; json: one machine-readable report",
    )
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from mse.api import check, load
    from mse.ir.anchors import read_speech, timeline_speech

    if args.timeline is None:
        return _run_dialogue(args)
    try:
        model = load(args.source)
        timelines = read_timelines(args.timeline)
        if any(t.episodes for t in timelines):
            where = "<stdin>" if args.timeline == "-" else args.timeline
            message = (f"this is a dialogue's timeline (episodes, each with its own set): check it alone, "
                       f"'mse check {args.timeline}'")
            raise MseError([Diagnostic("E100", message, Span(where))])
        speech = read_speech(args.speech) if args.speech else None
        models = [timeline_speech(model, timeline, speech, args.timeline) for timeline in timelines]
    except MseError as error:
        return print_error(error)
    failing = 0
    results = []
    for index, timeline in enumerate(timelines):
        label = f"timeline {index + 1}" if len(timelines) > 1 else "timeline"
        _say_rounded(timeline, label, args.timeline)
        violations = check(models[index], timeline)
        if violations:
            failing += 1
            for violation in violations if args.format == "text" else ():
                print(f"{violation.render()} [{label}]")
        if args.format == "json":
            results.append({"index": index + 1, "consistent": not violations, "violations": _json(violations)})
    ok = len(timelines) - failing
    if args.format == "json":
        report = {"expression": model.name, "timelines": len(timelines), "consistent": ok, "results": results}
        print(json.dumps(report, indent=2))
    elif not args.quiet:
        print(f"{ok} of {len(timelines)} timeline(s) consistent with {model.name}")
    return 1 if failing else 0


def _run_dialogue(args: argparse.Namespace) -> int:
    """``mse check dialogue.json``: every timeline's episodes, each against its own set."""
    from mse.dialogue.check import check_dialogue, model_loader

    path = args.source
    try:
        timelines = read_timelines(path)
        if not all(t.episodes for t in timelines):
            where = "<stdin>" if path == "-" else path
            message = ("this timeline has no episodes: give the behaviour set first "
                       f"('mse check SET {path}'); a dialogue's timeline (mse live) is checked alone")
            raise MseError([Diagnostic("E100", message, Span(where))])
        loader = model_loader()
        found = [check_dialogue(t, loader) for t in timelines]
    except MseError as error:
        return print_error(error)
    failing = sum(1 for violations in found if violations)
    if args.format == "json":
        results = [
            {"index": n + 1, "episodes": len(t.episodes), "consistent": not violations,
             "violations": [{**_json([v.violation])[0], "episode": v.episode, "emotion": v.emotion}
                            for v in violations]}
            for n, (t, violations) in enumerate(zip(timelines, found, strict=True))
        ]
        print(json.dumps({"timelines": len(timelines), "consistent": len(timelines) - failing, "results": results},
                         indent=2))
    else:
        for n, violations in enumerate(found):
            label = f" [timeline {n + 1}]" if len(timelines) > 1 else ""
            for violation in violations:
                print(violation.render() + label)
        if not args.quiet:
            episodes = sum(len(t.episodes) for t in timelines)
            bad = sum(len({v.episode for v in violations}) for violations in found)
            print(f"{len(timelines) - failing} of {len(timelines)} dialogue(s) consistent "
                  f"({episodes - bad} of {episodes} episodes)")
    return 1 if failing else 0


def _json(violations: list[Violation]) -> list[dict[str, Any]]:
    return [
        {
            "path": v.span.path,
            "line": v.span.line,
            "col": v.span.col,
            "kind": v.kind,
            "constraint": v.constraint,
            "signals": list(v.signals),
            "message": v.message,
        }
        for v in violations
    ]


def _say_rounded(timeline: Any, label: str, path: str) -> None:
    """Times are checked on the 1 ms grid of the semantics: say so when that rounds any."""
    from mse.ir.schedule import to_ticks

    off = [(signal, edge, value) for signal in timeline.signals
           for edge, value in (("start", signal.start), ("stop", signal.stop))
           if abs(value * 1000 - to_ticks(value)) > 1e-6]
    if off:
        signal, edge, value = off[0]
        more = f" (and {len(off) - 1} more)" if len(off) > 1 else ""
        where = "<stdin>" if path == "-" else path
        print(f"{where}: W309 [{label}] {signal.id} {edge} {value:g} s is finer than the 1 ms grid of the "
              f"semantics; checked as {to_ticks(value) / 1000:g} s{more}", file=sys.stderr)

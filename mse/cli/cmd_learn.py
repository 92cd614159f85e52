"""``mse learn FILES``: a behaviour set and constraint set from annotated recordings.

Inputs are ELAN files (``.eaf``), CSV/TSV tables (``sequence, tier, start, stop, label``) or
mse timelines (``.json``/``.jsonl``); docs/learn.md explains every step and number.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from mse.cli.common import add_quiet


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "learn",
        help="learn a behaviour set from annotations (ELAN, CSV/TSV, timelines)",
        description="Learn signals and constraints, with their evidence, from annotated sequences. "
        "Exit 1 on bad input; sequences that break a learned rule are listed on stderr.",
    )
    parser.add_argument("inputs", nargs="+", help=".eaf, .csv/.tsv, .json/.jsonl files or folders")
    add_quiet(parser)
    parser.add_argument("--tiers", help="tiers to read, each TIER or TIER=MODALITY (e.g. face,'Gaze R=gaze'); "
                        "default: every tier, its name as modality")
    parser.add_argument("--mapping", metavar="FILE", help="TOML file with [tiers] (tier = modality) and "
                        "[labels] (annotation value = signal id)")
    parser.add_argument("--name", help="expression name (default: the first input's name)")
    parser.add_argument("-o", "--output", help="write the behaviour set here (atomically) instead of stdout")
    parser.add_argument("--confidence", type=float, default=0.95,
                        help="least fraction of the sequences where a rule is tested in which it holds (default 0.95)")
    parser.add_argument("--min-support", type=int, default=10,
                        help="least number of sequences where a rule is tested (default 10)")
    parser.add_argument("--significance", type=float, default=0.001,
                        help="largest chance of seeing the evidence if the signals were independent (default 0.001)")
    parser.add_argument("--no-calibrate", action="store_true", help="keep the raw probability estimates")
    parser.add_argument("--seed", type=int, default=0, help="seed of the calibration samples (default 0)")
    parser.add_argument("--report", metavar="FILE", help="write the evidence, dropped rules and breaking "
                        "sequences as JSON")
    parser.set_defaults(handler=run)


def _mapping(args: argparse.Namespace) -> Any:
    from mse.diagnostics import Diagnostic, MseError, Span
    from mse.learn import TierMapping
    from mse.learn.corpus import identifier

    tiers: dict[str, str] = {}
    labels: dict[str, str] = {}
    if args.mapping:
        from mse.input_files import decode_utf8, parse_toml, read_input

        text = decode_utf8(read_input(args.mapping, what="mapping"), args.mapping, what="mapping")
        data = parse_toml(text, args.mapping, what="mapping")
        for table, target in (("tiers", tiers), ("labels", labels)):
            entries = data.get(table, {})
            if not isinstance(entries, dict) or not all(isinstance(v, str) for v in entries.values()):
                raise MseError([Diagnostic("E100", f"[{table}] must map names to strings", Span(args.mapping))])
            for key, value in entries.items():
                problem = _name_problem(value)
                if problem:
                    what = "modality" if table == "tiers" else "signal id"
                    raise MseError([Diagnostic("E100", f"[{table}] {key[:60]!r} = {value[:60]!r}: the {what} {problem}",
                                               Span(args.mapping, _line_of(text, key), 1))])
            target.update(entries)
    listed = bool(args.tiers) or bool(tiers)
    for item in (args.tiers or "").split(","):
        if not item.strip():
            continue
        tier, _, modality = item.partition("=")
        tiers[tier.strip()] = identifier(modality.strip() or tier.strip()).lower()
    return TierMapping(tiers, labels, only_listed=listed)


def _name_problem(name: str) -> str | None:
    """Why ``name`` cannot be a signal id or modality of the learned set (None: it can)."""
    from mse.ir.build import IDENTIFIER
    from mse.limits import MAX_NAME_CHARS

    if len(name) > MAX_NAME_CHARS:
        return f"is {len(name)} characters long (at most {MAX_NAME_CHARS})"
    if not IDENTIFIER.match(name):
        return "must be an identifier ([A-Za-z_][A-Za-z0-9_]*)"
    return None


def _line_of(text: str, key: str) -> int:
    """The line of ``text`` that defines ``key`` (0 when not found: a dotted or odd key)."""
    for number, line in enumerate(text.splitlines(), start=1):
        stripped = line.lstrip()
        if stripped.startswith((key, f'"{key}"', f"'{key}'")) and "=" in stripped:
            return number
    return 0


def _default_name(inputs: list[str]) -> str:
    from mse.learn.corpus import identifier

    stem = Path(inputs[0].rstrip("/\\")).stem
    return identifier(stem) or "learned"


def run(args: argparse.Namespace) -> int:
    from mse.cli.common import emit, print_diagnostics, print_error
    from mse.diagnostics import MseError, argument_error
    from mse.learn import LearnOptions, learn

    try:
        problems = []
        if not 0 < args.confidence <= 1:
            problems.append("--confidence must be in (0, 1]")
        if args.min_support < 1:
            problems.append("--min-support must be at least 1")
        if not 0 < args.significance <= 1:
            problems.append("--significance must be in (0, 1]")
        if problems:
            raise argument_error(*problems)
        options = LearnOptions(
            name=args.name or _default_name(args.inputs),
            confidence=args.confidence,
            min_support=args.min_support,
            significance=args.significance,
            calibrate=not args.no_calibrate,
            seed=args.seed,
        )
        result = learn(args.inputs, options, _mapping(args))
    except MseError as error:
        return print_error(error)
    print_diagnostics(result.diagnostics)
    inputs = [*args.inputs, *([args.mapping] if args.mapping else [])]
    try:
        emit(result.xml, args.output, inputs=inputs)
        _summary(result)
        if args.report:
            from mse.fileio import write_atomic

            write_atomic(args.report, json.dumps(_report(result), indent=2, ensure_ascii=False) + "\n", inputs=inputs)
    except MseError as error:  # -o or --report cannot be written (E105)
        return print_error(error)
    return 0


def _summary(result: Any) -> None:
    corpus = result.corpus
    broken = sorted({b.sequence for b in result.breaks})
    print(f"mse learn: {len(result.model.signals)} signals, {len(result.model.constraints)} constraints "
          f"({len(result.redundant)} candidate rules dropped as redundant or explained) from "
          f"{len(corpus.sequences)} sequences; {len(broken)} sequences break a learned rule", file=sys.stderr)
    for found in result.breaks[:20]:
        print(f"{found.span.render()}: sequence {found.sequence!r} breaks {found.rule}: {found.message}",
              file=sys.stderr)
    if len(result.breaks) > 20:
        print(f"... and {len(result.breaks) - 20} more (see --report)", file=sys.stderr)


def _report(result: Any) -> dict[str, Any]:
    from mse.ir.printer import expr_text

    def rule(r: Any) -> dict[str, Any]:
        return {"id": r.id, "kind": r.kind, "constraint": expr_text(r.expr), "support": r.support,
                "holds": r.holds, "confidence": r.confidence, "baseline": r.baseline, "p_value": r.p_value}

    return {
        "sequences": len(result.corpus.sequences),
        "typical_duration": result.corpus.typical_duration / 1000,
        "signals": {s.signal.id: s.evidence for s in result.signals},
        "rules": [rule(r) for r in result.rules],
        "dropped": [{**rule(r), "reason": reason} for r, reason in result.redundant],
        "breaks": [{"sequence": b.sequence, "where": b.span.render(), "rule": b.rule, "message": b.message}
                   for b in result.breaks],
        "calibration": result.calibration,
    }

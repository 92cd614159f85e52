"""``mse study analyze RESULTS... [-o DIR]``: a perception study's answers to its statistics.

``register(subparsers)`` adds ``analyze`` to the sub-commands of ``mse study``; the Markdown
report with its heatmaps (or the JSON) is explained in docs/study-analysis.md.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any


def register(subparsers: Any) -> None:
    from mse.study.analysis.statistics import CI_METHODS, CORRECTIONS, PREFERENCE_TESTS

    parser = subparsers.add_parser(
        "analyze",
        help="hit rates, κ, confusion matrices and believability tests from results CSVs",
        description="Analyse the answers of a perception study (results CSV files, or folders of them): "
        "hit rates with confidence intervals and tests against chance, the unbiased hit rate κ of the MSE "
        "paper's equation (1), confusion matrices, Fleiss' κ, believability preferences. Exit 1 on bad input.",
    )
    parser.add_argument("results", nargs="+", metavar="RESULTS", help="results .csv files or folders of them")
    parser.add_argument("-o", "--output", metavar="DIR",
                        help="write report.md, report.json and the heatmap PNGs into this folder "
                        "(without it the report goes to stdout, with no pictures)")
    parser.add_argument("--format", choices=("markdown", "json"), default="markdown",
                        help="what goes to stdout without -o (default markdown)")
    parser.add_argument("--labels", help="the labels offered to participants, comma-separated (default: the "
                        "intended emotions and responses seen); chance = 1 / their number")
    parser.add_argument("--ci", choices=tuple(CI_METHODS), default="wilson",
                        help="confidence interval of a proportion (default wilson)")
    parser.add_argument("--level", type=float, default=0.95, help="confidence level (default 0.95)")
    parser.add_argument("--alpha", type=float, default=0.05, help="significance level (default 0.05)")
    parser.add_argument("--correction", choices=tuple(CORRECTIONS), default="holm",
                        help="correction for multiple comparisons within each family of tests (default holm)")
    parser.add_argument("--preference-test", choices=PREFERENCE_TESTS, default="binomial",
                        help="test of a believability share against 0.5: exact binomial (default) or χ² "
                        "(the paper's)")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from mse.cli.common import print_error
    from mse.diagnostics import MseError
    from mse.study.analysis.analyze import Options, analyze
    from mse.study.analysis.report import to_json, to_markdown
    from mse.study.analysis.results import read_results, results_files

    labels = None if args.labels is None else tuple(part.strip() for part in args.labels.split(","))
    options = Options(labels=labels, ci=args.ci, level=args.level, alpha=args.alpha, correction=args.correction,
                      preference_test=args.preference_test)
    try:
        options.check()
        files = results_files(args.results)
        analysis = analyze(read_results(files), options, files)
        if args.output is None:
            text = json.dumps(to_json(analysis), indent=2, ensure_ascii=False) if args.format == "json" \
                else to_markdown(analysis)
            sys.stdout.write(text + "\n")
            return 0
        _write_folder(args.output, analysis, files)
    except MseError as error:
        return print_error(error)
    print(f"mse study analyze: {analysis.answers} answers from {analysis.participants} participants "
          f"-> {args.output}/report.md")
    return 0


def _write_folder(folder: str, analysis: Any, inputs: list[str]) -> None:
    """report.md, report.json and one heatmap per condition, all or nothing (a staged folder)."""
    from mse.fileio import staged_folder
    from mse.study.analysis.heatmap import heatmap_png
    from mse.study.analysis.report import to_json, to_markdown

    pictures = {c.condition: f"confusion-{c.condition}.png" for c in analysis.confusions}
    with staged_folder(folder, inputs=inputs) as staging:
        for confusion in analysis.confusions:
            (staging / pictures[confusion.condition]).write_bytes(heatmap_png(confusion))
        (staging / "report.md").write_text(to_markdown(analysis, pictures) + "\n", encoding="utf-8")
        (staging / "report.json").write_text(
            json.dumps(to_json(analysis), indent=2, ensure_ascii=False) + "\n", encoding="utf-8")

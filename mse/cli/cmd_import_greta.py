"""``mse import-greta``: Greta's MSE behaviour sets -> one native file per emotion.

    mse import-greta LEXICON CONSTRAINT -o OUTDIR
    mse import-greta --legacy example.xml -o OUTDIR

Warnings (W501 name repairs, W502 approximations) and errors go to stderr as
``path:line:col: CODE message``; exit 0 when every emotion was written, 1 on input errors
(nothing is written then), 2 on usage errors.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "import-greta",
        help="convert Greta's MSE behaviour sets (lexicon.xml + constraint.xml) to native files",
        description="Convert Greta's MSE behaviour sets to native MSE files, one per emotion "
        "(OUTDIR/<emotion>.xml). Every <behaviorset type=\"mse\"> of lexicon.xml is paired with "
        "the <multimodal emotion> of constraint.xml of the same name (a near match is paired with "
        "a W501 warning); a construct approximated in the conversion is a W502 warning at its "
        "file:line. Greta's data is GPL/LGPL: do not commit the converted files.",
    )
    parser.add_argument("files", nargs="*", metavar="FILE",
                        help="Greta's lexicon.xml and constraint.xml, in that order")
    parser.add_argument("--legacy", metavar="EXAMPLE",
                        help="read the legacy all-in-one example.xml instead")
    parser.add_argument("-o", "--output", required=True, metavar="OUTDIR",
                        help="folder for the <emotion>.xml files (created if missing)")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from mse.cli.common import print_diagnostics
    from mse.diagnostics import MseError, argument_error
    from mse.fileio import staged_folder, write_atomic
    from mse.syntax.greta import import_greta_legacy_report, import_greta_report

    files: list[str] = list(args.files)
    usage = None
    if args.legacy is not None and files:
        usage = "give either LEXICON CONSTRAINT or --legacy EXAMPLE, not both"
    elif args.legacy is None and len(files) != 2:
        usage = "expected LEXICON CONSTRAINT (or --legacy EXAMPLE)"
    if usage is not None:  # a usage error: exit 2, as argparse's own
        print_diagnostics(argument_error(usage).diagnostics)
        return 2
    try:
        report = (import_greta_legacy_report(args.legacy) if args.legacy is not None
                  else import_greta_report(files[0], files[1]))
    except MseError as error:
        for diagnostic in error.diagnostics:
            print(diagnostic.render(), file=sys.stderr)
        return 1
    for diagnostic in report.diagnostics:
        print(diagnostic.render(), file=sys.stderr)
    output = Path(args.output)
    inputs = [*files, *([args.legacy] if args.legacy else [])]
    try:
        with staged_folder(output, inputs=inputs) as staging:  # every file, or none
            for expression in report.expressions:
                write_atomic(staging / f"{expression.name}.xml", expression.xml)
        for expression in report.expressions:
            print(f"{output / f'{expression.name}.xml'}: {expression.signal_count} signals, "
                  f"{expression.constraint_count} constraints, "
                  f"{len(expression.diagnostics)} warnings")
    except MseError as error:
        for diagnostic in error.diagnostics:
            print(diagnostic.render(), file=sys.stderr)
        return 1
    return 0

"""``mse study``: TEMPORARY entry of the analyze branch (the study branch's cmd_study.py replaces it;
its sub-parsers get ``study_analyze.register``)."""

from __future__ import annotations

import argparse
import sys
from typing import Any


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser("study", help="perception studies: analyze the answers",
                                   description="Perception studies of the generated expressions.")
    commands = parser.add_subparsers(dest="study_command", metavar="STUDY_COMMAND")
    from mse.cli import study_analyze

    study_analyze.register(commands)
    parser.set_defaults(handler=_help(parser))


def _help(parser: argparse.ArgumentParser) -> Any:
    def run(_args: argparse.Namespace) -> int:
        parser.print_help(sys.stderr)
        return 2

    return run

"""``mse lma CLIP.bvh``: the LMA Effort and Shape components of a clip."""

from __future__ import annotations

import argparse
import json
import math
from typing import Any


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "lma",
        help="LMA Effort/Shape components of a BVH clip",
        description="Print the Laban Effort (Weight, Time, Flow) and Shape components of a BVH "
        "clip, for the whole body and per body part (Samadani et al., §III-A).",
    )
    parser.add_argument("clip", nargs="+", help="BVH file(s)")
    parser.add_argument("--format", choices=("json", "text"), default="json", help="json (default) or text")
    parser.add_argument("-o", "--output", help="write to this file instead of stdout")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from mse.cli.common import emit, print_error
    from mse.diagnostics import Diagnostic, MseError, Span
    from mse.motion.base.bvh import read_bvh
    from mse.motion.base.lma import format_text, lma_features

    results = {}
    try:
        for path in args.clip:
            results[path] = lma_features(read_bvh(path), path=path)
            if not _finite(results[path].to_json()):  # e.g. a skeleton of zero size
                message = "the clip's LMA components are not finite numbers (degenerate skeleton?)"
                raise MseError([Diagnostic("E100", message, Span(path))])
        if args.format == "json":
            if len(results) == 1:
                payload: Any = next(iter(results.values())).to_json()
            else:
                payload = {path: features.to_json() for path, features in results.items()}
            emit(json.dumps(payload, indent=2, allow_nan=False) + "\n", args.output, inputs=args.clip)
        else:
            blocks = [
                (f"{path}\n" if len(results) > 1 else "") + format_text(features)
                for path, features in results.items()
            ]
            emit("\n".join(blocks), args.output, inputs=args.clip)
    except MseError as error:
        return print_error(error)
    return 0


def _finite(value: Any) -> bool:
    if isinstance(value, float):
        return math.isfinite(value)
    if isinstance(value, dict):
        return all(_finite(v) for v in value.values())
    if isinstance(value, list | tuple):
        return all(_finite(v) for v in value)
    return True

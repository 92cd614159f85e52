"""Action fidelity of both motion methods, every action and style of a library.

    python -m bench.evaluation.motion_fidelity --library ../shared/motion/bandai-ds1
    python -m bench.evaluation.motion_fidelity --library ../shared/motion/bandai-ds2 --methods lma-hmm
    python -m bench.evaluation.motion_fidelity --library ../shared/motion/bandai-ds2 --length-factors 1,2,3
    python -m bench.evaluation.motion_fidelity --library starter --filmstrips docs/images

For each action of the library, a reference is measured on its real clips
(:mod:`bench.evaluation.fidelity`: the action's signature measures and their spread, foot
slip, jerk); then every method generates the action in every style the library holds for
it, lasting the median length of that style's real clips, through the same generator
interface as ``mse animate``, and the checks are applied: the signature within the real
spread, foot slip and jerk at most 2x the real median, bone lengths constant; a travelling
action's step rate within the real spread and no frame moving the root backwards more than a
real take's. ``--length-factors 1,2,3`` also asks for 2x and 3x the real length. One line per
(method, action, style), failures marked ``!``; a summary per method at the end and a
markdown table with ``--markdown``. ``--filmstrips DIR`` writes real-vs-generated PNGs for
the cases named by ``--strip action:style`` (repeatable). Models and paths are cached under
``$MSE_CACHE_DIR`` (default ``.cache-mse``).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from bench.evaluation.fidelity import Check, Reference, check, measure, reference, repeated
from mse.motion.base.library import MotionLibrary, MotionUnavailable, load_library
from mse.motion.base.starter import starter_library
from mse.motion.generator import METHODS, GenerationRequest, generator_for


def _library(location: str) -> MotionLibrary:
    return starter_library() if location == "starter" else load_library(location)


def _format(checks: list[Check]) -> str:
    parts = []
    for c in checks:
        mark = "" if c.passed else "!"
        if np.isfinite(c.low):
            parts.append(f"{c.name}={c.value:.1f}{mark}[{c.low:.1f},{c.high:.1f}]")
        else:
            parts.append(f"{c.name}={c.value:.2f}{mark}(<={c.high:.1f})")
    return " ".join(parts)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--library", required=True, help="library folder, or 'starter'")
    parser.add_argument("--methods", default=",".join(METHODS))
    parser.add_argument("--actions", help="comma-separated (default: all)")
    parser.add_argument("--styles", help="comma-separated (default: all the action has)")
    parser.add_argument("--max-reference", type=int, default=120, help="real clips measured per action (spread evenly)")
    parser.add_argument(
        "--length-factors",
        default="1",
        help="comma-separated: each case is generated lasting these multiples of the style's median real length",
    )
    parser.add_argument("--markdown", action="store_true", help="also print a markdown summary table")
    parser.add_argument("--filmstrips", help="folder for real-vs-generated PNGs")
    parser.add_argument("--strip", action="append", default=[], metavar="ACTION:STYLE")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    cache = os.environ.get("MSE_CACHE_DIR", ".cache-mse")
    library = _library(args.library)
    methods = args.methods.split(",")
    generators = {m: generator_for(m, cache) for m in methods}
    actions = args.actions.split(",") if args.actions else library.actions()
    strips = {tuple(s.split(":", 1)) for s in args.strip}
    factors = [float(f) for f in args.length_factors.split(",")]
    results: dict[str, list[tuple[str, str, bool, list[str]]]] = {m: [] for m in methods}
    started = time.perf_counter()
    for action in actions:
        clips = library.select(action)
        if not clips:
            print(f"{action}: no clip", file=sys.stderr)
            continue
        step = max(1, len(clips) // args.max_reference)
        reference_motions = [library.motion(c) for c in clips[::step]]
        action_reference = reference(action, reference_motions)
        repeated_references: dict[float, Reference] = {}
        styles = sorted({c.style for c in clips})
        if args.styles:
            styles = [s for s in styles if s in args.styles.split(",")]
        print(f"== {action} ({len(clips)} clips; signature {', '.join(action_reference.signature)})")
        for style in styles:
            own = [library.motion(c) for c in clips if c.style == style]
            style_reference = reference(action, own[:: max(1, len(own) // 40)])
            real_length = float(np.median([m.duration for m in own]))
            for factor, method in ((f, m) for f in factors for m in generators):
                generator = generators[method]
                duration = factor * real_length
                if factor not in repeated_references:
                    # a standing cycle's rate and amplitude measured over a clip include its rise
                    # and fall: at a longer length they are those of the real takes repeated
                    repeated_references[factor] = repeated(action_reference, reference_motions, factor)
                checked = repeated_references[factor]
                clock = time.perf_counter()
                request = GenerationRequest(action, style, duration)
                case = f"{style} x{factor:g}" if len(factors) > 1 else style
                try:
                    motion = generator.generate(library, request)
                except MotionUnavailable as reason:
                    print(f"  {method:8s} {case:18s} unavailable: {reason}")
                    results[method].append((action, case, False, ["unavailable"]))
                    continue
                checks = check(measure(motion), checked, style_reference)
                failed = [c.name for c in checks if not c.passed]
                results[method].append((action, case, not failed, failed))
                took = time.perf_counter() - clock
                print(f"  {method:8s} {case:18s} {took:5.1f}s {'ok  ' if not failed else 'FAIL'} {_format(checks)}")
                if args.filmstrips and ((action, style) in strips or (action, "*") in strips):
                    from filmstrip import filmstrip

                    name = f"{Path(args.library).name}_{action}_{style}_{method}.png"
                    filmstrip([(f"real {style}", own[0]), (f"{method} {style}", motion)], Path(args.filmstrips) / name)
    print(f"\n{time.perf_counter() - started:.0f} s")
    for method, rows in results.items():
        passed = sum(ok for *_, ok, _ in rows)
        print(f"{method}: {passed}/{len(rows)} (action, style) pass")
        for action, style, ok, failed in rows:
            if not ok:
                print(f"   fails: {action} {style}: {', '.join(failed)}")
    if args.markdown:
        print("\n| method | action | styles passing | failing |")
        print("|---|---|---|---|")
        for method, rows in results.items():
            for action in actions:
                mine = [r for r in rows if r[0] == action]
                if not mine:
                    continue
                bad = [f"{s} ({', '.join(f)})" for _, s, ok, f in mine if not ok]
                print(f"| {method} | {action} | {sum(r[2] for r in mine)}/{len(mine)} | {'; '.join(bad) or '-'} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

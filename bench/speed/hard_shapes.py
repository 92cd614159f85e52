"""The default sampler on the hard shapes of issue 32 (item 3): precedes ladders, equalities
with tolerance, exclusion cycles, implies chains, late mandatory signals (generator:
bench/generators/hard_shapes.py).  Prints numbers; asserts nothing.

    python -m bench.speed.hard_shapes                          # 150 sets x 5 seeds
    python -m bench.speed.hard_shapes --sets 40 --seeds 3      # quicker
    python -m bench.speed.hard_shapes --baseline main          # the same sets, another version
    python -m bench.speed.hard_shapes --sizes 100,200,400      # only the sets of these sizes
    python -m bench.speed.hard_shapes --markdown bench/results/hard_shapes.md

CP-SAT is the ground truth (only sets it proves feasible count) and the baseline measured in
the same run: its time for one timeline of each set.  Per shape and per size: the share of
runs the walk alone solves (target >= 95 %), CP-SAT fallbacks, backtracks per timeline, p50 /
p99 time per timeline of the default solver, wall and CPU (target p99 <= 500 ms up to 400
signals) and the ratio of CP-SAT's median time to it.  With ``--baseline REF`` the same job also runs on
another version (bench/baseline.py), alternately in the same run.
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections import defaultdict
from collections.abc import Collection, Sequence
from pathlib import Path
from typing import Any

from bench.baseline import add_argument, baseline_tree
from bench.generators.hard_shapes import SHAPES, corpus, hard_model
from bench.speed.runner import run_job
from bench.speed.sample import item, load_line, percentile
from mse.ir import model as ir
from mse.solve.protocol import NoSolution, SolveRequest, get_solver

Feasible = tuple[str, int, ir.Model, float, float]


def feasible_sets(
    count: int, seed: int, time_limit: float, sizes: Collection[int] | None = None
) -> tuple[list[Feasible], int]:
    """The sets CP-SAT proves feasible, each with (shape, size, model, duration, CP-SAT time
    of one timeline); and how many it did not.  ``sizes``: only the corpus' sets of these
    numbers of signals (the same sets as in the whole corpus)."""
    cpsat = get_solver("cpsat")
    found: list[Feasible] = []
    other = 0
    for model_seed, size, shape, duration in corpus(count, seed):
        if sizes is not None and size not in sizes:
            continue
        model = hard_model(model_seed, size, shape, duration)
        began = time.perf_counter()
        try:
            cpsat.solve(model, SolveRequest(duration=duration, seed=0, time_limit=time_limit))
        except NoSolution:
            other += 1
            continue
        found.append((shape, size, model, duration, time.perf_counter() - began))
    return found, other


def summarize(rows: Sequence[dict[str, Any]]) -> dict[str, float]:
    methods = [m for r in rows for m in r["methods"]]
    times = [t for r in rows for t in r["times"]]
    cpu = [t for r in rows for t in r.get("cpu_times", ())]
    runs = len(methods)
    return {
        "runs": runs,
        "walk": sum(1 for m in methods if m == "walk") / max(1, runs),
        "fallbacks": sum(1 for m in methods if m == "cpsat"),
        "failed": sum(1 for m in methods if not m),
        "backtracks": sum(r["restarts"] for r in rows) / max(1, runs),
        "p50": percentile(times, 0.5),
        "p99": percentile(times, 0.99),
        "cpu_p99": percentile(cpu, 0.99),
    }


def table(title: str, keys: Sequence[Any], groups: dict[Any, list[int]], sides: Sequence[Sequence[dict[str, Any]]],
          labels: Sequence[str], cpsat: dict[Any, list[float]]) -> list[str]:
    lines = [f"| {title} | sets | runs | " + " | ".join(
        f"{label}: walk alone | fallbacks | backtracks/tl | p50 ms | p99 ms | CPU p99 ms" for label in labels)
        + " | CP-SAT p50 ms | CP-SAT / default p50 |",
        "|" + "---|" * (4 + 6 * len(labels)) + "---|"]
    for key in keys:
        members = groups.get(key, [])
        if not members:
            continue
        cells = []
        first: dict[str, float] | None = None
        for side in sides:
            found = summarize([side[i] for i in members])
            first = first or found
            cells.append(f"{found['walk']:.1%} | {found['fallbacks']:.0f} | {found['backtracks']:.2f} | "
                         f"{found['p50'] * 1000:.1f} | {found['p99'] * 1000:.1f} | {found['cpu_p99'] * 1000:.1f}")
        assert first is not None
        cp = statistics.median(cpsat[key]) * 1000
        lines.append(f"| {key} | {len(members)} | {first['runs']:.0f} | " + " | ".join(cells)
                     + f" | {cp:.0f} | {cp / max(first['p50'] * 1000, 1e-3):.0f}x |")
    return lines


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sets", type=int, default=150, help="sets generated (CP-SAT keeps the feasible ones)")
    parser.add_argument("--seeds", type=int, default=5, help="timelines (seeds) per set")
    parser.add_argument("--seed", type=int, default=32, help="seed of the corpus")
    parser.add_argument("--time-limit", type=float, default=30.0, help="CP-SAT's limit per set, seconds")
    parser.add_argument("--markdown", type=Path, help="also write the tables to this file")
    parser.add_argument("--sizes", type=lambda text: {int(size) for size in text.split(",")},
                        help="only the corpus' sets of these sizes (signals), comma-separated: 100,200,400")
    add_argument(parser)
    args = parser.parse_args(argv)
    print(f"== hard shapes (bench/generators/hard_shapes.py, corpus seed {args.seed}); {load_line()}", flush=True)
    began = time.perf_counter()
    sets, other = feasible_sets(args.sets, args.seed, args.time_limit, args.sizes)
    sizes = f" of {', '.join(map(str, sorted(args.sizes)))} signals" if args.sizes else ""
    print(f"CP-SAT ({args.time_limit:g} s per set): {len(sets)} sets{sizes} of {args.sets} feasible, "
          f"{other} not proved ({time.perf_counter() - began:.0f} s)", flush=True)
    job = [item(model.name, model, duration, range(args.seeds), warm=0) for _, _, model, duration, _ in sets]
    sides = [run_job(None, job)]
    labels = ["this tree"]
    with baseline_tree(args.baseline) as root:
        if root is not None:
            sides.append(run_job(root, job))
            labels.append(f"baseline {args.baseline}")
    by_shape: dict[str, list[int]] = defaultdict(list)
    by_size: dict[int, list[int]] = defaultdict(list)
    cp_shape: dict[str, list[float]] = defaultdict(list)
    cp_size: dict[int, list[float]] = defaultdict(list)
    for index, (shape, size, _, _, cp_time) in enumerate(sets):
        by_shape[shape].append(index)
        by_size[size].append(index)
        cp_shape[shape].append(cp_time)
        cp_size[size].append(cp_time)
    every = list(range(len(sets)))
    lines = [f"{len(sets)} feasible sets x {args.seeds} seeds; time per timeline of the default solver "
             f"(walk, then CP-SAT when it gives up), wall clock, one process; {load_line()}", ""]
    lines += table("shape", [*SHAPES, "mixed"], dict(by_shape), sides, labels, dict(cp_shape))
    lines.append("")
    lines += table("signals", sorted(by_size), dict(by_size), sides, labels, dict(cp_size))
    lines.append("")
    lines += table("all", ["all"], {"all": every}, sides, labels, {"all": [s[4] for s in sets]})
    total = summarize(sides[0])
    lines += ["", f"walk alone: {total['walk']:.1%} of runs (target >= 95 %); p99 {total['p99'] * 1000:.0f} ms, "
                  f"CPU {total['cpu_p99'] * 1000:.0f} ms (target <= 500 ms up to 400 signals); failed "
                  f"{total['failed']:.0f} (target 0)"]
    text = "\n".join(lines)
    print(text)
    if args.markdown is not None:
        args.markdown.write_text(
            "# The default sampler on hard shapes (issue 32)\n\n"
            "`python -m bench.speed.hard_shapes` (bench/generators/hard_shapes.py; docs/sampler.md).\n\n"
            + text + "\n")


if __name__ == "__main__":
    main()

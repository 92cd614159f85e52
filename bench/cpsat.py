"""Benchmark of the CP-SAT backend: python bench/cpsat.py [--runs N] [--greta DIR].

Prints, per bundled emotion and timeline length (4, 10, 30 s), p50/p95 of model build +
solve in milliseconds (import excluded, one warm-up run); the time to explain an
infeasible set; and the time of the solver-backed lint over all bundled sets (and over
the imported Greta sets when their folder is given or found in MSE_SHARED).
Targets (issue 4): p50 <= 20 ms and p95 <= 100 ms at 10 s; lint of the bundled sets <= 5 s.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from mse.api import load, loads  # noqa: E402
from mse.resources import bundled_names  # noqa: E402
from mse.solve.cpsat import CpSatSolver  # noqa: E402
from mse.solve.cpsat.deep_lint import deep_lint  # noqa: E402
from mse.solve.cpsat.explain import explain  # noqa: E402
from mse.solve.protocol import SolveRequest  # noqa: E402

CONFLICT = REPO / "tests" / "fixtures" / "solvers" / "conflict.xml"


def percentile(values: list[float], fraction: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(fraction * (len(ordered) - 1)))]


def bench_sampling(runs: int) -> None:
    solver = CpSatSolver()
    solver.solve(load(bundled_names()[0]), SolveRequest(duration=10.0))  # import + warm-up
    print(f"{'emotion':15s} {'D':>4s} {'p50 ms':>8s} {'p95 ms':>8s}")
    all_at_10: list[float] = []
    for name in bundled_names():
        model = load(name)
        for duration in (4.0, 10.0, 30.0):
            times = []
            for seed in range(runs):
                started = time.perf_counter()
                solver.solve(model, SolveRequest(duration=duration, seed=seed))
                times.append(1000 * (time.perf_counter() - started))
            if duration == 10.0:
                all_at_10.extend(times)
            print(f"{name:15s} {duration:4g} {statistics.median(times):8.1f} {percentile(times, 0.95):8.1f}")
    print(f"{'all':15s} {10:4g} {statistics.median(all_at_10):8.1f} {percentile(all_at_10, 0.95):8.1f}")


def bench_diverse() -> None:
    solver = CpSatSolver()
    times = []
    for name in bundled_names():
        started = time.perf_counter()
        solver.solve(load(name), SolveRequest(duration=10.0, seed=1, count=3, diverse=True))
        times.append(1000 * (time.perf_counter() - started))
    print(f"--count 3 --diverse at 10 s: p50 {statistics.median(times):.0f} ms, "
          f"max {max(times):.0f} ms over the bundled sets")


def bench_csp() -> None:
    from mse.solve.csp import CspSolver

    model = load(REPO / "tests" / "fixtures" / "solvers" / "tiny.xml")
    times = []
    for seed in range(10):
        started = time.perf_counter()
        CspSolver().solve(model, SolveRequest(duration=4.0, seed=seed, grid=0.5))
        times.append(1000 * (time.perf_counter() - started))
    print(f"csp tiny.xml at 4 s on a 0.5 s grid: p50 {statistics.median(times):.1f} ms")


def bench_explain() -> None:
    model = load(CONFLICT)
    started = time.perf_counter()
    explanation = explain(model, 2.0)
    elapsed = 1000 * (time.perf_counter() - started)
    size = len(explanation.items) if explanation else 0
    print(f"explain {CONFLICT.name} at 2 s: {elapsed:.1f} ms, {size} items")
    for name in bundled_names():
        model = load(name)
        everything = tuple(s.id for s in model.signals)
        started = time.perf_counter()
        explanation = explain(model, 4.0, require=everything)
        elapsed = 1000 * (time.perf_counter() - started)
        size = f"{len(explanation.items)} items" if explanation else "feasible"
        print(f"explain {name} at 4 s with every signal required: {elapsed:.1f} ms, {size}")


def bench_lint(greta: Path | None) -> None:
    started = time.perf_counter()
    count = 0
    for name in bundled_names():
        count += len(deep_lint(load(name), 10.0))
    print(f"deep lint of {len(bundled_names())} bundled sets: {time.perf_counter() - started:.2f} s, "
          f"{count} findings")
    if greta is None or not (greta / "lexicon.xml").is_file():
        return
    from mse.syntax.greta import import_greta

    imported = import_greta(greta / "lexicon.xml", greta / "constraint.xml")
    started = time.perf_counter()
    count = 0
    for expression in imported:
        count += len(deep_lint(loads(expression.xml, path=expression.name), 10.0))
    print(f"deep lint of {len(imported)} imported Greta sets: {time.perf_counter() - started:.2f} s, "
          f"{count} findings")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=20)
    shared = Path(os.environ.get("MSE_SHARED", REPO.parent / "shared"))
    parser.add_argument("--greta", type=Path, default=shared / "greta")
    args = parser.parse_args()
    bench_sampling(args.runs)
    bench_diverse()
    bench_csp()
    bench_explain()
    bench_lint(args.greta)


if __name__ == "__main__":
    main()

"""Start-up of ``mse sample --duration 10`` (the main job), warm and cold compiled-model cache.

    python -m bench.speed.startup [--runs 15] [--baseline REF]

Prints the median wall time of each case and its ratio to ``python -c pass`` measured in
the same run (the machine is shared: absolute times are noisy, ratios less so), and the
modules that take longest to import (``-X importtime``).  ``--baseline REF`` (a git revision
or a source tree, bench/baseline.py) runs the same cases with that version, interleaved with
this one.

Cases: *warm* reuses one cache folder (the compiled model is read from the cache: neither
lxml nor lark is imported); *cold* gets a fresh cache folder each run (the file is parsed,
the constraint parser built, the cache entry written).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench.baseline import NEUTRAL, add_argument, baseline_tree, environment

SAMPLE = ["-m", "mse", "sample", "--duration", "10", "--seed", "1", "--format", "json"]


def _run(arguments: list[str], env: dict[str, str]) -> float:
    began = time.perf_counter()
    subprocess.run([sys.executable, *arguments], env=env, check=True, capture_output=True, cwd=NEUTRAL)
    return time.perf_counter() - began


def _env(tree: Path | None, cache: str) -> dict[str, str]:
    env = environment(tree, MSE_CACHE_DIR=cache)
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # start-up as installed: bytecode cached
    return env


def _importtime(tree: Path | None, cache: str) -> list[tuple[int, str]]:
    done = subprocess.run(
        [sys.executable, "-X", "importtime", *SAMPLE],
        env=_env(tree, cache),
        capture_output=True,
        text=True,
        check=True,
        cwd=NEUTRAL,
    )
    rows = []
    for line in done.stderr.splitlines():
        if line.startswith("import time:") and "|" in line and "cumulative" not in line:
            _, cumulative, name = line.split("|")
            rows.append((int(cumulative), name.rstrip()))
    top_level = [(us, name.strip()) for us, name in rows if not name.startswith("    ")]
    return sorted(top_level, reverse=True)[:8]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--runs", type=int, default=15)
    add_argument(parser)
    args = parser.parse_args()
    with baseline_tree(args.baseline) as root:
        return measure(args.runs, args.baseline, root)


def measure(runs: int, reference: str | None, root: Path | None) -> int:
    trees: list[tuple[str, Path | None]] = [("this tree", None)]
    if root is not None:
        trees.insert(0, (f"baseline ({reference})", root))
    with tempfile.TemporaryDirectory() as scratch:
        warm = {label: str(Path(scratch) / f"warm-{n}") for n, (label, _) in enumerate(trees)}
        for label, tree in trees:  # fill each warm cache once
            _run(SAMPLE, _env(tree, warm[label]))
        results: dict[str, list[float]] = {"python -c pass": []}
        for _ in range(runs):
            results["python -c pass"].append(_run(["-c", "pass"], dict(os.environ)))
            for label, tree in trees:
                results.setdefault(f"{label}: warm", []).append(_run(SAMPLE, _env(tree, warm[label])))
                cold = tempfile.mkdtemp(dir=scratch)
                results.setdefault(f"{label}: cold", []).append(_run(SAMPLE, _env(tree, cold)))
        baseline = statistics.median(results["python -c pass"])
        print(f"mse sample --duration 10, median of {runs} runs (ratio to python -c pass)")
        for name, times in results.items():
            median = statistics.median(times)
            print(f"  {name:<48} {median * 1000:7.0f} ms  {median / baseline:5.1f}x")
        for label, tree in trees:
            print(f"slowest top-level imports, {label}, warm cache (cumulative ms):")
            for micros, module in _importtime(tree, warm[label]):
                print(f"  {micros / 1000:7.1f}  {module}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

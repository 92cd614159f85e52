"""Benchmarks of the default sampler (issues 3, 12 and 19).  Prints numbers; asserts nothing.

    python -m bench.speed.sample --sets                 # every bundled and Greta set, 10 s
    python -m bench.speed.sample --bytecodes --count 100   # the same, in bytecodes per timeline (load-free)
    python -m bench.speed.sample --corpus               # random sets, CP-SAT as ground truth
    python -m bench.speed.sample --growth               # growth exponents, 200/400 at 10 s
    python -m bench.speed.sample --scale                # 200 signals / 400 constraints at 10 s only
    python -m bench.speed.sample --long                 # one-hour timelines: rate, memory, stream
    python -m bench.speed.sample --infeasible           # time to a proof (CLI, up to 50 signals)
    python -m bench.speed.sample --fidelity             # per-signal rates against the definition
    python -m bench.speed.sample --constraint-less      # the control condition
    python -m bench.speed.sample --cli                  # start time of `mse sample`
    ... --baseline main                                 # compare with another version (a revision or a path)

The machine is shared: with ``--baseline REF`` every speed is also given as a ratio against
that version (bench/baseline.py: a git revision or a source tree), measured in the same run, in
a subprocess alternately with this tree (bench/speed/runner.py).  The load average is printed
before and after.  Greta's sets are imported from ``$MSE_SHARED/greta`` (default ../shared).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import random
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from bench.baseline import add_argument, baseline_tree, run_python
from bench.generators.corpus import planted_model, random_model
from bench.speed.runner import run_job
from mse.api import load, loads
from mse.ir import model as ir
from mse.ir.canonical import model_to_json
from mse.ir.evaluate import check_schedule
from mse.resources import bundled_names
from mse.solve.protocol import NoSolution, SolveRequest, get_solver

REPO = Path(__file__).resolve().parent.parent.parent

GRETA_EMOTIONS = (
    "anger", "anxiety", "embarrassment", "joy", "panic_fear", "pride", "regret", "rejoice", "relief", "tension",
)


def load_line(note: str = "") -> str:
    return f"load average {os.getloadavg()[0]:.2f} (2 cores, shared){note}"


def percentile(values: Sequence[float], fraction: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(fraction * (len(ordered) - 1)))] if ordered else float("nan")


def slope(xs: Sequence[float], ys: Sequence[float]) -> float:
    """Least-squares slope of log(y) against log(x): the growth exponent."""
    lx = [math.log(x) for x in xs]
    ly = [math.log(max(y, 1e-9)) for y in ys]
    mx, my = statistics.mean(lx), statistics.mean(ly)
    return sum((a - mx) * (b - my) for a, b in zip(lx, ly, strict=True)) / sum((a - mx) ** 2 for a in lx)


def greta_models() -> dict[str, ir.Model]:
    shared = Path(os.environ.get("MSE_SHARED", REPO.parent / "shared"))
    lexicon, constraint = shared / "greta" / "lexicon.xml", shared / "greta" / "constraint.xml"
    if not lexicon.exists():
        print(f"(Greta's data not found under {shared}: Greta sets skipped)")
        return {}
    from mse.syntax.greta import import_greta_report

    report = import_greta_report(lexicon, constraint)
    return {
        f"greta:{e.name}": loads(e.xml, path=f"greta/{e.name}.xml")
        for e in report.expressions if e.name in GRETA_EMOTIONS
    }


def all_sets() -> dict[str, ir.Model]:
    found = {name: load(name) for name in bundled_names()}
    found.update(greta_models())
    return found


class Compare:
    """Runs the same job on this tree and on the baseline revision, alternately."""

    def __init__(self, baseline: str | None, root: Path | None) -> None:
        self.baseline_root = root
        self.baseline = baseline

    def run(self, job: list[dict[str, Any]], baseline_solver: str = "greedy") -> tuple[list[dict[str, Any]], ...]:
        mine = run_job(None, job)
        if self.baseline_root is None:
            return (mine,)
        theirs = run_job(self.baseline_root, [{**item, "solver": baseline_solver} for item in job])
        return mine, theirs


def item(name: str, model: ir.Model, duration: float, seeds: Sequence[int], solver: str = "greedy",
         warm: int = 3) -> dict[str, Any]:
    return {"name": name, "model": model_to_json(model), "duration": duration, "seeds": list(seeds),
            "solver": solver, "warm": warm}


# -- --sets: every bundled and Greta set (issue 19) ------------------------------------------------
def bench_sets(compare: Compare, count: int, duration: float, rounds: int = 1, only: Sequence[str] = ()) -> None:
    """Per set, ``rounds`` runs of this tree and the baseline alternately; the best CPU rate
    of each side counts (the least disturbed run of a loaded machine)."""
    sets = {name: model for name, model in all_sets().items() if not only or name in only}
    print(f"== timelines per second, in-process, {duration:g} s, {count} timelines per set "
          f"(one process; CPU time of that process; best of {rounds} round(s); {load_line()})")
    header = f"{'set':24s} {'tl/s (CPU)':>11s} {'tl/s wall':>10s} {'backtracks/tl':>13s} {'fallbacks':>9s}"
    if compare.baseline:
        header += f" {'baseline tl/s':>13s} {'ratio':>6s} {'baseline fails':>14s}"
    print(header)
    worst = math.inf
    for name, model in sets.items():
        job = [item(name, model, duration, range(1, count + 1))]
        runs = [compare.run(job) for _ in range(max(1, rounds))]
        results = tuple(min((run[side] for run in runs), key=lambda r: r[0]["cpu"]) for side in range(len(runs[0])))
        mine = results[0][0]
        rate, wall_rate = count / mine["cpu"], count / mine["wall"]
        worst = min(worst, rate)
        fallbacks = sum(1 for m in mine["methods"] if m == "cpsat")
        line = (f"{name:24s} {rate:11.0f} {wall_rate:10.0f} {mine['restarts'] / count:13.3f} "
                f"{fallbacks:9d}")
        if len(results) > 1:
            theirs = results[1][0]
            base = count / theirs["cpu"]
            line += f" {base:13.0f} {rate / base:6.2f} {count - theirs['ok']:14d}"
        print(line, flush=True)
    print(f"slowest set: {worst:.0f} timelines per CPU second (target >= 4000); {load_line()}")


# -- --bytecodes: the same work counted in bytecodes (load-independent) -------------------------------
BYTECODES_SCRIPT = r"""
import json, sys
from mse.ir.canonical import model_from_json
from mse.solve.protocol import NoSolution, SolveRequest, get_solver
job = json.load(sys.stdin)
results = []
for item in job:
    model = model_from_json(item["model"], path=item["name"])
    solver = get_solver("greedy")
    def run(seeds):
        for seed in seeds:
            try:
                solver.solve(model, SolveRequest(duration=item["duration"], seed=seed))
            except NoSolution:
                pass
    run(range(10**6, 10**6 + 100))  # plans built, checks generated: the steady state is counted
    count = [0]
    def tracer(frame, event, arg):
        frame.f_trace_opcodes = True
        if event == "opcode":
            count[0] += 1
        return tracer
    sys.settrace(tracer)
    run(item["seeds"])
    sys.settrace(None)
    results.append({"name": item["name"], "bytecodes": count[0] / len(item["seeds"])})
print(json.dumps(results))
"""


def bench_bytecodes(compare: Compare, count: int, duration: float, only: Sequence[str] = ()) -> None:
    """Per set, the Python bytecodes executed per timeline (sys.settrace opcode events, a
    loop of one solve() per seed as --sets) by this tree and the baseline: the same for any
    load, so a ratio that the shared machine's noise does not move (C calls count as one)."""
    sets = {name: model for name, model in all_sets().items() if not only or name in only}
    print(f"== bytecodes per timeline, {duration:g} s, {count} timelines per set after 100 not counted "
          f"(instruction counts: independent of the load; {load_line()})")
    print(f"{'set':24s} {'bytecodes/tl':>12s} {'baseline':>10s} {'ratio':>6s}")
    job = [{"name": name, "model": model_to_json(model), "duration": duration, "seeds": list(range(1, count + 1))}
           for name, model in sets.items()]
    roots = [None] + ([compare.baseline_root] if compare.baseline_root is not None else [])
    counts = []
    for root in roots:
        done = run_python(root, ["-c", BYTECODES_SCRIPT], stdin=json.dumps(job), check=True)
        counts.append({r["name"]: r["bytecodes"] for r in json.loads(done.stdout.strip().splitlines()[-1])})
    for name in sets:
        line = f"{name:24s} {counts[0][name]:12.0f}"
        if len(counts) > 1:
            line += f" {counts[1][name]:10.0f} {counts[1][name] / counts[0][name]:6.2f}"
        print(line)


# -- --corpus: random sets with CP-SAT as ground truth (issue 12) ------------------------------------
def corpus_sizes(count: int, seed: int) -> list[tuple[int, int, int, float]]:
    rng = random.Random(seed)
    sizes = []
    for index in range(count):
        n = rng.randint(3, 40)
        sizes.append((seed * 100_000 + index, n, rng.randint(max(1, n // 2), 2 * n), rng.choice((4.0, 10.0, 30.0))))
    return sizes


def bench_corpus(compare: Compare, count: int, seeds: int, seed: int, time_limit: float) -> None:
    cpsat = get_solver("cpsat")
    feasible: list[tuple[str, ir.Model, float]] = []
    infeasible = unknown = 0
    began = time.perf_counter()
    for model_seed, n, m, duration in corpus_sizes(count, seed):
        model = random_model(model_seed, n, m)
        try:
            cpsat.solve(model, SolveRequest(duration=duration, seed=0, time_limit=time_limit))
            feasible.append((model.name, model, duration))
        except NoSolution as failure:
            if failure.proven:
                infeasible += 1
            else:
                unknown += 1
    print(f"== corpus: {count} random sets (3-40 signals, n/2-2n constraints, 4/10/30 s, bench/generators/corpus.py, "
          f"seed {seed}); CP-SAT ({time_limit:g} s): {len(feasible)} feasible, {infeasible} infeasible, "
          f"{unknown} undecided ({time.perf_counter() - began:.0f} s)")
    job = [item(name, model, duration, range(seeds), warm=0) for name, model, duration in feasible]
    results = compare.run(job)
    mine = results[0]
    failed_sets = sum(1 for r in mine if r["ok"] < seeds)
    failed = sum(seeds - r["ok"] for r in mine)
    # CP-SAT's timeline is a fallback whether or not the chain stage follows it ("cpsat+chain")
    fallback_sets = sum(1 for r in mine if any(m.startswith("cpsat") for m in r["methods"]))
    fallbacks = sum(1 for r in mine for m in r["methods"] if m.startswith("cpsat"))
    times = [t for r in mine for t in r["times"]]
    by_method: dict[str, list[float]] = {}
    for r in mine:
        for t, m in zip(r["times"], r["methods"], strict=False):
            by_method.setdefault(m, []).append(t)
    total = len(feasible) * seeds
    print(f"default solver on the {len(feasible)} feasible sets x {seeds} seeds: "
          f"failed {failed}/{total} timelines ({failed / max(1, total):.2%}) on {failed_sets} sets (target 0)")
    print(f"  CP-SAT fallbacks: {fallbacks} ({fallbacks / max(1, total):.2%}, on {fallback_sets} sets)")
    print(f"  time per timeline: p50 {percentile(times, 0.5) * 1000:.1f} ms, "
          f"p99 {percentile(times, 0.99) * 1000:.1f} ms")
    for method, spent in sorted(by_method.items(), key=lambda item: -len(item[1])):
        print(f"  made by {method}: {len(spent)}, p50 {percentile(spent, 0.5) * 1000:.1f} ms, "
              f"p99 {percentile(spent, 0.99) * 1000:.1f} ms")
    if len(results) > 1:
        theirs = results[1]
        old_failed = sum(seeds - r["ok"] for r in theirs)
        old_sets = sum(1 for r in theirs if r["ok"] < seeds)
        old_times = [t for r in theirs for t in r["times"]]
        old_fallbacks = sum(r["methods"].count("cpsat") for r in theirs)
        old_fallback_sets = sum(1 for r in theirs if "cpsat" in r["methods"])
        print(f"baseline ({compare.baseline}): failed {old_failed}/{total} timelines "
              f"({old_failed / max(1, total):.2%}) on {old_sets} sets; CP-SAT fallbacks {old_fallbacks} "
              f"(on {old_fallback_sets} sets); p50 {percentile(old_times, 0.5) * 1000:.1f} ms, "
              f"p99 {percentile(old_times, 0.99) * 1000:.1f} ms")
        ratios = [b / a for a, b in zip(times, old_times, strict=True) if a > 0 and b > 0]
        print(f"  speed ratio baseline/default per timeline: median {statistics.median(ratios):.2f}, "
              f"geometric mean {math.exp(statistics.mean(math.log(r) for r in ratios)):.2f}; "
              f"total time {sum(old_times):.1f} s (baseline) vs {sum(times):.1f} s (default)")
    print(load_line())


# -- --growth: exponents in signals, constraints, duration; 200 signals / 400 constraints -----------
def bench_growth(compare: Compare, models: int, seeds: int) -> None:
    series: dict[str, list[tuple[float, int, int, float]]] = {
        "signals (constraints = 2 x signals, 10 s)": [(n, n, 2 * n, 10.0) for n in (12, 25, 50, 100, 200)],
        "constraints (50 signals, 10 s)": [(m, 50, m, 10.0) for m in (12, 25, 50, 100, 200)],
        "duration (20 signals, 30 constraints)": [(d, 20, 30, d) for d in (5.0, 10.0, 30.0, 60.0, 120.0)],
    }
    print(f"== growth: planted sets (a random timeline drawn first, then random constraints it satisfies, "
          f"bench/generators/corpus.py), {models} sets x {seeds} seeds per point; median time per timeline; "
          f"{load_line()}")
    for title, points in series.items():
        xs, mine_medians, theirs_medians = [], [], []
        print(title)
        for x, n, m, duration in points:
            job = [{**item(f"p{k}", planted_model(1000 * k + n + m, n, m, duration), duration, range(seeds), warm=1),
                    "budget": 120.0} for k in range(models)]
            results = compare.run(job)
            times = [t for r in results[0] for t in r["times"]]
            failed = sum(seeds - r["ok"] for r in results[0])
            fallbacks = sum(r["methods"].count("cpsat") for r in results[0])
            xs.append(x)
            mine_medians.append(statistics.median(times))
            line = (f"  {x:6g}: p50 {statistics.median(times) * 1000:8.1f} ms  "
                    f"p99 {percentile(times, 0.99) * 1000:8.1f} ms  failed {failed}  fallbacks {fallbacks}")
            if len(results) > 1:
                old = [t for r in results[1] for t in r["times"]]
                skipped = sum(r.get("skipped", 0) for r in results[1])
                old_failed = sum(seeds - r["ok"] for r in results[1]) - skipped
                theirs_medians.append(statistics.median(old))
                line += (f"  | baseline p50 {statistics.median(old) * 1000:8.1f} ms failed {old_failed}"
                         f"{f' (+{skipped} not run: 120 s per set spent)' if skipped else ''}"
                         f"  ratio {statistics.median(old) / statistics.median(times):5.2f}")
            print(line, flush=True)
        line = f"  growth exponent: {slope(xs, mine_medians):.2f}"
        if theirs_medians:
            line += f" (baseline {slope(xs, theirs_medians):.2f})"
        print(line)
    print(load_line())


# -- --scale: the 200 signals / 400 constraints point alone, repeated (issue 12) --------------------
def bench_scale(compare: Compare, models: int, seeds: int, repeat: int) -> None:
    """The 200/400 point of --growth, ``repeat`` times, this tree and the baseline alternately:
    p50/p99 per timeline, failures, fallbacks, backtracks per timeline, ratio of the medians."""
    print(f"== scale: planted sets of 200 signals / 400 constraints at 10 s (bench/generators/corpus.py), "
          f"{models} sets x "
          f"{seeds} seeds, {repeat} rounds; the first timeline of each set (plan building) not counted; "
          f"{load_line()}")
    job = [{**item(f"p{k}", planted_model(1000 * k + 600, 200, 400, 10.0), 10.0, range(seeds), warm=1),
            "budget": 300.0} for k in range(models)]
    ratios = []
    for round_ in range(repeat):
        results = compare.run(job)
        line = f"  round {round_ + 1}:"
        medians = []
        for label, result in zip(("default", f"baseline {compare.baseline}"), results, strict=False):
            times = [t for r in result for t in r["times"]]
            failed = sum(seeds - r["ok"] for r in result) - sum(r.get("skipped", 0) for r in result)
            fallbacks = sum(r["methods"].count("cpsat") for r in result)
            restarts = sum(r["restarts"] for r in result) / max(1, len(times))
            medians.append(statistics.median(times))
            cpu = [t for r in result for t in r.get("cpu_times", ())]
            walks = [t for r in result for t, m in zip(r.get("cpu_times", ()), r["methods"], strict=False)
                     if m == "walk"]
            line += (f"  {label}: p50 {medians[-1] * 1000:7.1f} ms p99 {percentile(times, 0.99) * 1000:8.1f} ms "
                     f"(CPU p50 {statistics.median(cpu) * 1000 if cpu else math.nan:7.1f} ms p99 "
                     f"{percentile(cpu, 0.99) * 1000 if cpu else math.nan:8.1f} ms; walks alone: CPU p50 "
                     f"{statistics.median(walks) * 1000 if walks else math.nan:6.1f} ms) "
                     f"failed {failed} fallbacks {fallbacks} backtracks/tl {restarts:5.1f} |")
        if len(medians) > 1:
            ratios.append(medians[1] / medians[0])
            line += f" ratio {ratios[-1]:.2f}"
        print(line, flush=True)
    if ratios:
        print(f"  baseline/default ratio of the p50: median {statistics.median(ratios):.2f} over {repeat} rounds")
    print(f"target: p50 <= 50 ms, no failure; {load_line()}")


# -- --long: one-hour timelines ---------------------------------------------------------------------
LONG_SCRIPT = r"""
import json, sys, time, resource
import mse.api as api
from mse.solve.protocol import SolveRequest, get_solver
def rss():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4096 / 2**20
path, duration = sys.argv[1], float(sys.argv[2])
model = api.load(path)
solver = get_solver("greedy")
before = rss()
began = time.perf_counter()
first = None
marks = {}  # minute of the timeline -> [wall time of the first occurrence starting in it, RSS then]
count = 0
for occurrence in solver.stream(model, SolveRequest(duration=duration, seed=1)):
    now = time.perf_counter() - began
    if first is None:
        first = now
    count += 1
    minute = occurrence.start // 60000
    if minute not in marks:
        marks[minute] = [now, rss()]
total = time.perf_counter() - began
print(json.dumps({"total": total, "first": first, "count": count, "before": before, "after": rss(),
                  "peak": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, "marks": marks}))
"""


def bench_long(duration: float, names: Sequence[str]) -> None:
    """One long timeline per set in a fresh process, consumed from ``stream()``.  The cost of
    a stretch of timeline is the wall time between the hand-out of the first occurrence
    starting in it and of the first one starting after it."""
    print(f"== one timeline of {duration:g} s per set, streamed (--stream), in a fresh process; {load_line()}")
    print(f"{'set':24s} {'wall s':>7s} {'x real':>7s} {'first s':>8s} {'signals':>8s} {'RSS MB: start':>13s} "
          f"{'10 min':>7s} {'end':>6s}   {'wall s for minutes 0-10 / last 10':>34s}")
    sets = all_sets()
    with tempfile.TemporaryDirectory() as folder:
        for name in names:
            path = Path(folder) / f"{name.replace(':', '_')}.json"
            path.write_text(json.dumps(model_to_json(sets[name])), encoding="utf-8")
            done = run_python(None, ["-c", LONG_SCRIPT, str(path), str(duration)])
            if done.returncode != 0:
                print(f"{name:24s} failed: {done.stderr[-300:]}")
                continue
            data = json.loads(done.stdout.strip().splitlines()[-1])
            marks = {int(k): v for k, v in data["marks"].items()}
            last = int(duration // 60)

            def at(minute: int, marks: dict[int, list[float]] = marks, total: float = data["total"]) -> float:
                later = [marks[m][0] for m in marks if m >= minute]
                return min(later) if later else total

            head, tail = at(10) - at(0), data["total"] - at(last - 10)
            rss10 = next((marks[m][1] for m in sorted(marks) if m >= 10), data["after"])
            first = data["first"] if data["first"] is not None else float("nan")
            print(f"{name:24s} {data['total']:7.2f} {duration / data['total']:7.0f} {first:8.3f} {data['count']:8d} "
                  f"{data['before']:13.1f} {rss10:7.1f} {data['after']:6.1f}   {head:16.3f} / {tail:.3f}",
                  flush=True)
    print(load_line())


# -- --infeasible: proofs ----------------------------------------------------------------------------
def cli_run(root: Path | None, args: list[str]) -> tuple[subprocess.CompletedProcess[str], float, float]:
    """``mse ARGS`` with the package of ``root`` (None: this checkout) in a fresh interpreter:
    the process, its wall time and its CPU time."""
    began, usage = time.perf_counter(), resource.getrusage(resource.RUSAGE_CHILDREN)
    done = run_python(root, ["-m", "mse", *args])
    wall = time.perf_counter() - began
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return done, wall, after.ru_utime + after.ru_stime - usage.ru_utime - usage.ru_stime


def bench_infeasible(compare: Compare, count: int, seed: int, time_limit: float, repeat: int) -> None:
    cpsat = get_solver("cpsat")
    found: list[tuple[ir.Model, float]] = []
    for model_seed, n, m, duration in corpus_sizes(count * 10, seed + 7):
        if len(found) >= count:
            break
        n = max(n, 7)
        model = random_model(model_seed, n, m)
        try:
            cpsat.solve(model, SolveRequest(duration=duration, seed=0, time_limit=time_limit))
        except NoSolution as failure:
            if failure.proven:
                found.append((model, duration))
    # and the largest: 50 signals
    rng = random.Random(seed)
    for attempt in range(200):
        if len(found) >= count + 3:
            break
        model = random_model(seed * 7919 + attempt, 50, rng.randint(25, 60))
        try:
            cpsat.solve(model, SolveRequest(duration=10.0, seed=0, time_limit=time_limit))
        except NoSolution as failure:
            if failure.proven:
                found.append((model, 10.0))
    print(f"== infeasible sets: `mse sample SET.json --seed 1` (compiled IR), wall and CPU time to the proof, "
          f"best of {repeat} runs{f', and the baseline {compare.baseline} alternately' if compare.baseline else ''}; "
          f"{load_line()}")
    walls, cpus, ratios = [], [], []
    with tempfile.TemporaryDirectory() as folder:
        for model, duration in found:
            path = Path(folder) / f"{model.name}.json"
            path.write_text(json.dumps(model_to_json(model)), encoding="utf-8")
            args = ["sample", str(path), "--seed", "1", "--duration", str(duration)]
            runs: dict[str, list[tuple[subprocess.CompletedProcess[str], float, float]]] = {"mine": [], "base": []}
            for _ in range(repeat):
                runs["mine"].append(cli_run(None, args))
                if compare.baseline_root is not None:
                    runs["base"].append(cli_run(compare.baseline_root, args))
            done = runs["mine"][0][0]
            wall, cpu = min(r[1] for r in runs["mine"]), min(r[2] for r in runs["mine"])
            walls.append(wall)
            cpus.append(cpu)
            proof = "no timeline of" in done.stderr
            line = done.stderr.strip().splitlines()[0][:80] if done.stderr.strip() else ""
            text = (f"  {len(model.signals):3d} signals {len(model.constraints):3d} constraints {duration:4g} s: "
                    f"exit {done.returncode} wall {wall:5.2f} s CPU {cpu:5.2f} s proof {proof}")
            if runs["base"]:
                base_wall, base_cpu = min(r[1] for r in runs["base"]), min(r[2] for r in runs["base"])
                ratios.append(base_cpu / cpu)
                text += f" | baseline wall {base_wall:5.2f} s CPU {base_cpu:5.2f} s, CPU ratio {ratios[-1]:4.2f}"
            print(f"{text}  {line}", flush=True)
    print(f"max wall {max(walls):.2f} s, max CPU {max(cpus):.2f} s (target 2 s)"
          + (f"; baseline/default CPU ratio: median {statistics.median(ratios):.2f}, min {min(ratios):.2f}"
             if ratios else "") + f"; {load_line()}")


# -- --fidelity -------------------------------------------------------------------------------------
def bench_fidelity(count: int, cp_count: int, duration: float, draws: int, names: Sequence[str] | None) -> None:
    from bench.evaluation.reference import prior_statistics, sample_reference
    from bench.evaluation.reference import statistics as signal_statistics

    sets = all_sets()
    if names:
        sets = {k: v for k, v in sets.items() if k in names}
    print(f"== probability fidelity at {duration:g} s: target = prior (mse/ir/profile.py) conditioned on "
          f"consistency, by rejection from {draws} prior draws when >= 200 are consistent, else the prior's own "
          f"prediction; walk: {count} timelines; CP-SAT (on this tree): {cp_count} timelines; {load_line()}")
    print("rate: once-only signals, fraction of timelines; repetitive (*): occurrences per 10 s.  start: mean, s.")
    worst: dict[str, list[float]] = {"walk rate": [], "cpsat rate": [], "walk start": [], "cpsat start": []}
    agreement: list[float] = []
    for name, model in sets.items():
        reference = sample_reference(model, duration, wanted=draws, seed=1, max_draws=draws)
        acceptance = reference.acceptance
        if len(reference.accepted) >= 200:
            wanted, how = signal_statistics(model, reference.accepted, duration), "rejection"
        else:
            wanted, how = prior_statistics(model, duration), "prior"
        sampled = {}
        for solver_name, number in (("greedy", count), ("cpsat", cp_count)):
            solver = get_solver(solver_name)
            schedules = []
            for seed in range(number):
                with contextlib.suppress(NoSolution):
                    schedules.extend(solver.solve(model, SolveRequest(duration=duration, seed=seed)).schedules)
            sampled[solver_name] = signal_statistics(model, schedules, duration)
        print(f"-- {name}: target by {how} (acceptance {acceptance:.1%})")
        print(f"   {'signal':24s} {'target':>7s} {'walk':>6s} {'cpsat':>6s}   {'start':>6s} {'walk':>6s} {'cpsat':>6s}")
        for signal in model.signals:
            sid = signal.id
            mark = "*" if signal.repetitive else ""

            def fmt(value: float | None) -> str:
                return "     -" if value is None or value != value else f"{value:6.2f}"

            walk, cp = sampled["greedy"], sampled["cpsat"]
            print(f"   {sid + mark:24s} {fmt(wanted.rate[sid]):>7s} {fmt(walk.rate[sid])} {fmt(cp.rate[sid])}   "
                  f"{fmt(wanted.start[sid])} {fmt(walk.start[sid])} {fmt(cp.start[sid])}")
            if how == "rejection" and not signal.repetitive:
                worst["walk rate"].append(abs(walk.rate[sid] - wanted.rate[sid]))
                worst["cpsat rate"].append(abs(cp.rate[sid] - wanted.rate[sid]))
                for key, got in (("walk start", walk.start[sid]), ("cpsat start", cp.start[sid])):
                    if got is not None and wanted.start[sid] is not None and wanted.rate[sid] > 0.1:
                        worst[key].append(abs(got - wanted.start[sid]))  # type: ignore[operator]
            if not signal.repetitive:
                agreement.append(abs(walk.rate[sid] - cp.rate[sid]))
    print("over the sets whose target comes from rejection sampling (once-only signals; start: signals with "
          "target rate > 0.1):")
    for key, values in worst.items():
        if values:
            unit = " s" if "start" in key else ""
            print(f"   |{key} - target|: median {statistics.median(values):.3f}{unit}, "
                  f"90th percentile {percentile(values, 0.9):.3f}{unit}, max {max(values):.3f}{unit}")
    if agreement:
        print(f"walk vs CP-SAT occurrence rate, every once-only signal of every set: median |difference| "
              f"{statistics.median(agreement):.3f}, 90th percentile {percentile(agreement, 0.9):.3f}, "
              f"max {max(agreement):.3f}")
    print(load_line())


# -- --constraint-less --------------------------------------------------------------------------------
def bench_constraint_less(count: int) -> None:
    print(f"== --mode constraint-less: {count} timelines per set; every one must violate a constraint; {load_line()}")
    for name, model in all_sets().items():
        if not model.constraints:
            continue
        solver = get_solver("greedy")
        began = time.perf_counter()
        try:
            result = solver.solve(model, SolveRequest(duration=10.0, seed=1, count=count, mode="constraint-less"))
        except NoSolution as failure:
            print(f"  {name:24s} failed: {failure.reason[:120]}")
            continue
        elapsed = time.perf_counter() - began
        schedules, methods = result.schedules, result.methods
        violating = sum(1 for s in schedules if any(v.kind == "constraint" for v in check_schedule(model, s)))
        structural = sum(1 for s in schedules if any(v.kind != "constraint" for v in check_schedule(model, s)))
        print(f"  {name:24s} violate >= 1 constraint: {violating}/{len(schedules)}, structural errors {structural}, "
              f"fallbacks {sum(1 for m in methods if m != 'walk')}, {elapsed / count * 1000:.2f} ms each")


# -- --cli ----------------------------------------------------------------------------------------------
def wall_times(commands: list[list[str]], repeat: int, env: dict[str, str]) -> list[float]:
    """Median wall time in seconds of each command over ``repeat`` runs.  Each is run once
    first (not counted: it writes the byte-code cache), then the commands alternate, so a
    change of load on the machine affects them alike."""
    def run(command: list[str]) -> float:
        started = time.perf_counter()
        subprocess.run(command, cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False, env=env)
        return time.perf_counter() - started

    for command in commands:
        run(command)
    times: list[list[float]] = [[] for _ in commands]
    for _ in range(repeat):
        for index, command in enumerate(commands):
            times[index].append(run(command))
    return [statistics.median(found) for found in times]


def bench_cli(repeat: int) -> None:
    """``mse sample --duration 10`` against ``python -c pass``, byte-code cached as for an
    installed user (PYTHONDONTWRITEBYTECODE, set in this environment, is removed for these
    subprocesses; the cache goes to a temporary PYTHONPYCACHEPREFIX)."""
    import shutil

    executable = shutil.which("mse", path=str(Path(sys.executable).parent)) or ""
    cli = [executable] if executable else [sys.executable, "-m", "mse"]
    command = [*cli, "sample", "--duration", "10", "--seed", "1", "--format", "json"]
    with tempfile.TemporaryDirectory() as cache:
        env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
        env["PYTHONPYCACHEPREFIX"] = cache
        bare, sample = wall_times([[sys.executable, "-c", "pass"], command], repeat, env)
    print(f"== CLI start (median of {repeat}, one warm-up run not counted): python -c pass {bare * 1000:.1f} ms, "
          f"mse sample --duration 10 {sample * 1000:.1f} ms, ratio {sample / bare:.2f}x (target <= 10x)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    modes: dict[str, Callable[[], None]] = {}
    for flag in ("sets", "bytecodes", "corpus", "growth", "scale", "long", "infeasible", "fidelity",
                 "constraint-less", "cli"):
        parser.add_argument(f"--{flag}", action="store_true")
    add_argument(parser)
    parser.add_argument("--count", type=int, default=2000,
                        help="--sets: timelines per set (--bytecodes: at most 200)")
    parser.add_argument("--duration", type=float, default=None, help="--sets (10), --long (3600), --fidelity (10)")
    parser.add_argument("--corpus-size", type=int, default=400, help="--corpus: random sets")
    parser.add_argument("--seeds", type=int, default=5, help="--corpus, --growth: seeds per set")
    parser.add_argument("--models", type=int, default=8, help="--growth: sets per point")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--time-limit", type=float, default=10.0, help="CP-SAT ground truth, seconds")
    parser.add_argument("--sets-only", nargs="*", default=None, help="--sets, --long, --fidelity: these sets only")
    parser.add_argument("--draws", type=int, default=20000, help="--fidelity: prior draws per set")
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--rounds", type=int, default=2, help="--sets, --scale, --infeasible: repetitions")
    args = parser.parse_args()

    print(load_line(" before"))
    needs_compare = args.sets or args.bytecodes or args.corpus or args.growth or args.scale or args.infeasible
    reference = args.baseline if needs_compare else None
    with baseline_tree(reference) as root:
        compare = Compare(reference, root)
        modes = {
            "sets": lambda: bench_sets(compare, args.count, args.duration or 10.0, args.rounds, args.sets_only or ()),
            "bytecodes": lambda: bench_bytecodes(compare, min(args.count, 200), args.duration or 10.0,
                                                 args.sets_only or ()),
            "corpus": lambda: bench_corpus(compare, args.corpus_size, args.seeds, args.seed, args.time_limit),
            "growth": lambda: bench_growth(compare, args.models, args.seeds),
            "long": lambda: bench_long(args.duration or 3600.0, args.sets_only or list(all_sets())),
            "scale": lambda: bench_scale(compare, args.models, args.seeds, args.rounds),
            "infeasible": lambda: bench_infeasible(compare, 10, args.seed, args.time_limit, args.rounds),
            "fidelity": lambda: bench_fidelity(1000, 200, args.duration or 10.0, args.draws, args.sets_only),
            "constraint_less": lambda: bench_constraint_less(200),
            "cli": lambda: bench_cli(args.repeat),
        }
        chosen = [name for name in modes if getattr(args, name)]
        for name in chosen or ["sets"]:
            modes[name]()
    print(load_line(" after"))


if __name__ == "__main__":
    main()

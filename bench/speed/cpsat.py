"""Benchmark of the CP-SAT backend and of solver-backed lint (issue 12; earlier issue 4).

    python -m bench.speed.cpsat                    # every section, no baseline
    python -m bench.speed.cpsat --sections scale,lint --baseline main
    python -m bench.speed.cpsat --quick            # fewer runs, for a smoke test

Every measurement runs in its own process (bench/speed/cpsat_measure.py), once against this
checkout and, where the section says "vs", once against ``--baseline REF`` (bench/baseline.py:
a git revision or a source tree), so that ratios are measured in the same run on the same
(shared, noisy) machine.  The load average is printed with each
section.  Sections:

* ``sampling``: model build + solve per bundled set at 10 s, p50/p95 (vs baseline);
* ``scale``: generated feasible sets (planted timeline, bench/generators/cpsat_sets.py) of 50/100 and
  200/400 signals/constraints at 10 s, p50/p95 (target 200/400: p50 <= 1 s; vs baseline);
* ``explain``: generated infeasible sets of 10-50 signals: time to "no timeline" with its proof
  and minimal explanation (target <= 2 s at 50 signals);
* ``long``: a 1-hour timeline of every bundled set: wall time, real-time factor, peak memory,
  the cost of the first and of the last quarter, and occurrences per signal against the
  profile's expectation (prior draws of the same hour);
* ``lint``: deep lint of the bundled and imported Greta sets, and of generated sets of
  125-1000 constraints (grouped signals; and ungrouped) with the growth exponent (target:
  about linear, 1000 constraints <= 5 s; vs baseline);
* ``controls``: ``--mode constraint-less`` timelines that violate a constraint, and
  occurrences of a signal whose probabilities are both 0 (each signal muted in turn), for
  CP-SAT and the default solver on every bundled and imported Greta set;
* ``fidelity``: per-signal occurrence rate and mean start of CP-SAT and of the greedy walk
  against rejection sampling of the target, on every bundled and imported Greta set.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from bench.baseline import add_argument, baseline_tree, describe, run_python

REPO = Path(__file__).resolve().parent.parent.parent
SECTIONS = ("sampling", "scale", "explain", "long", "lint", "fidelity", "controls")


def load_average() -> str:
    return " ".join(f"{x:.1f}" for x in os.getloadavg())


def measure(kind: str, root: Path | None = None, **arguments: Any) -> dict[str, Any]:
    """Run one measurement in a fresh process against ``root`` (None: this checkout)."""
    done = run_python(root, ["-m", "bench.speed.cpsat_measure", kind, json.dumps(arguments)])
    if done.returncode != 0:
        return {"error": done.stderr.strip().splitlines()[-1] if done.stderr.strip() else "failed"}
    result: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    return result


def pct(values: Sequence[float], fraction: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(fraction * (len(ordered) - 1)))]


def ms(values: Sequence[float]) -> str:
    return f"{1000 * statistics.median(values):8.1f} {1000 * pct(values, 0.95):8.1f}"


def ratio(new: float, old: float) -> str:
    return f"{old / new:6.1f}x" if new > 0 else "     -"


def section_sampling(args: argparse.Namespace, base: Path | None) -> None:
    print(f"\n## sampling: bundled sets at 10 s, model build + solve, ms (load {load_average()})")
    runs = 5 if args.quick else 20
    new = measure("bundled", duration=10.0, runs=runs)
    old = measure("bundled", base, duration=10.0, runs=runs) if base else {}
    print(f"{'set':15s} {'p50':>8s} {'p95':>8s} {'CPU p50':>8s} {'p95':>8s}   baseline p50/p95 "
          f"CPU p50/p95   speed-up(p50, CPU p50)")
    everything, before, used, used_before = [], [], [], []
    for name, times in new["times"].items():
        everything += times
        used += new.get("cpu", {}).get(name, [])
        line = f"{name:15s} {ms(times)} {ms(new['cpu'][name]) if 'cpu' in new else ''}"
        if old.get("times"):
            speed = ratio(statistics.median(times), statistics.median(old["times"][name]))
            cpu_speed = ratio(statistics.median(new["cpu"][name]), statistics.median(old["cpu"][name]))
            line += f"   {ms(old['times'][name])} {ms(old['cpu'][name])}   {speed} {cpu_speed}"
            before += old["times"][name]
            used_before += old["cpu"][name]
        print(line)
    line = f"{'all':15s} {ms(everything)} {ms(used) if used else ''}"
    if before:
        wall_speed = ratio(statistics.median(everything), statistics.median(before))
        cpu_speed = ratio(statistics.median(used), statistics.median(used_before))
        line += f"   {ms(before)} {ms(used_before)}   {wall_speed} {cpu_speed}"
    print(line)
    print("target (issue 4): p50 <= 20 ms and p95 <= 100 ms per set")


def section_scale(args: argparse.Namespace, base: Path | None) -> None:
    print(f"\n## scale: generated feasible sets at 10 s, seconds (load {load_average()})")
    sets = 4 if args.quick else 12
    print("wall seconds p50/p95, then CPU seconds p50 (one CP-SAT worker: CPU time does not depend on "
          "other jobs' load)")
    print(f"{'signals/constraints':20s} {'p50':>7s} {'p95':>7s} {'fail':>5s} {'cpu50':>6s}   "
          "baseline p50/p95/fail   speed-up(p50)")
    for signals, constraints in ((50, 100), (100, 200), (200, 400)):
        new = measure("scale", signals=signals, constraints=constraints, sets=sets, duration=10.0)
        line = (f"{signals}/{constraints:<16d} {statistics.median(new['times']):7.2f} {pct(new['times'], 0.95):7.2f} "
                f"{new['failures']:5d} {statistics.median(new['cpu']):6.2f}")
        if base:
            old = measure("scale", base, signals=signals, constraints=constraints, sets=min(sets, 4), duration=10.0)
            if "times" in old:
                speed = ratio(statistics.median(new["times"]), statistics.median(old["times"]))
                line += (f"   {statistics.median(old['times']):7.2f} {pct(old['times'], 0.95):7.2f} "
                         f"{old['failures']:4d}   {speed}")
        print(line)
    # The same size from the default sampler's generator (bench/generators/corpus.py, planted timeline).
    new = measure("scale", signals=200, constraints=400, sets=sets, duration=10.0, generator="corpus")
    if "times" in new:
        print(f"{'200/400 corpus.py':20s} {statistics.median(new['times']):7.2f} {pct(new['times'], 0.95):7.2f} "
              f"{new['failures']:5d} {statistics.median(new['cpu']):6.2f}")
    else:
        print(f"200/400 corpus.py: {new.get('error')}")
    print("target: 200/400 p50 <= 1 s")


def section_explain(args: argparse.Namespace, base: Path | None) -> None:
    print(f"\n## explain: generated infeasible sets at 10 s, seconds (load {load_average()})")
    sets = 4 if args.quick else 10
    print(f"{'signals':8s} {'sample+proof p50':>17s} {'max':>6s} {'explain p50':>12s} {'max':>6s}  "
          "proven minimal items")
    for signals in (10, 25, 50):
        new = measure("explain", signals=signals, constraints=2 * signals, sets=sets, duration=10.0)
        rows = new["rows"]
        first = [r["sample_and_proof"] for r in rows]
        second = [r["explain"] for r in rows]
        print(f"{signals:<8d} {statistics.median(first):17.2f} {max(first):6.2f} {statistics.median(second):12.2f} "
              f"{max(second):6.2f}  {sum(r['proven'] for r in rows)}/{len(rows)} "
              f"{sum(r['minimal'] for r in rows)}/{len(rows)} {statistics.median(r['items'] for r in rows):g}")
    print("target: <= 2 s at 50 signals (sample+proof includes the explanation)")


def section_long(args: argparse.Namespace, base: Path | None) -> None:
    duration = 600.0 if args.quick else 3600.0
    print(f"\n## long: one {duration:g} s timeline per bundled set (load {load_average()})")
    from mse.resources import bundled_names

    for name in bundled_names():
        new = measure("long", name=name, duration=duration, seed=1)
        if "error" in new:
            print(f"{name}: {new['error']}")
            continue
        expected = measure("long_prior", name=name, duration=duration)
        quarters = new.get("quarters") or [0.0, 0.0]
        cpu = new.get("cpu", float("nan"))
        print(f"{name}: {new['seconds']:.1f} s ({duration / new['seconds']:.0f}x real time; CPU {cpu:.1f} s, "
              f"{duration / cpu:.0f}x), "
              f"peak {new['peak_mb']:.0f} MB, first/last quarter {quarters[0]:.1f}/{quarters[1]:.1f} s")
        counts, prior = new["counts"], expected.get("counts", {})
        cells = [f"{signal} {counts.get(signal, 0)}/{prior.get(signal, 0):.1f}"
                 for signal in sorted(set(counts) | set(prior))]
        print("   occurrences sampled/prior expectation: " + ", ".join(cells))
        if base and name == "anxiety":
            old = measure("long", base, name=name, duration=duration, seed=1)
            if "counts" in old:
                print(f"   baseline: {old['seconds']:.1f} s, occurrences {old['counts']}")


def _exponent(sizes: Sequence[int], seconds: Sequence[float]) -> float:
    xs, ys = [math.log(s) for s in sizes], [math.log(max(t, 1e-6)) for t in seconds]
    mx, my = statistics.mean(xs), statistics.mean(ys)
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys, strict=True)) / sum((x - mx) ** 2 for x in xs)


def section_lint(args: argparse.Namespace, base: Path | None) -> None:
    print(f"\n## lint: deep lint at 10 s, seconds (load {load_average()})")
    greta = Path(args.greta_sets) if args.greta_sets else None
    for label, folder in (("bundled", "bundled"), ("Greta", str(greta) if greta else None)):
        if folder is None:
            continue
        new = measure("lint", constraints=0, locality=None, mandatory=1.0, folder=folder)
        line = (f"{label:8s} {new.get('seconds', float('nan')):6.2f} s (CPU {new.get('cpu', float('nan')):5.2f} s) "
                f"{new.get('codes')}")
        if base:
            old = measure("lint", base, constraints=0, locality=None, mandatory=1.0, folder=folder)
            line += f"   baseline {old.get('seconds', float('nan')):6.2f} s {old.get('codes')}"
        print(line)
    sizes = (125, 250, 500) if args.quick else (125, 250, 500, 1000)
    for label, locality, mandatory in (("grouped (10)", 10, 0.3), ("ungrouped", None, 1.0)):
        seconds, cpus = [], []
        for constraints in sizes:
            new = measure("lint", constraints=constraints, locality=locality, mandatory=mandatory, folder=None)
            seconds.append(new.get("seconds", float("nan")))
            cpus.append(new.get("cpu", float("nan")))
            line = (f"{label:12s} {constraints:5d} constraints: {seconds[-1]:7.2f} s (CPU "
                    f"{cpus[-1]:6.2f} s) {new.get('codes')}")
            if base:
                old = measure("lint", base, constraints=constraints, locality=locality, mandatory=mandatory,
                              folder=None)
                old_cpu = old.get("cpu", float("nan"))
                line += (f"   baseline {old.get('seconds', float('nan')):7.2f} s (CPU {old_cpu:6.2f} s, "
                         f"CPU ratio {old_cpu / max(cpus[-1], 1e-9):4.2f}) {old.get('codes')}")
            print(line)
        print(f"{label}: growth exponent {_exponent(sizes, seconds):.2f} in wall time, {_exponent(sizes, cpus):.2f} "
              "in CPU time (1 = linear)")
        if not args.quick:
            full = measure("lint", constraints=sizes[-1], locality=locality, mandatory=mandatory, folder=None,
                           full=True)
            print(f"{label:12s} {sizes[-1]:5d} constraints, every question asked (--deep-budget 0): "
                  f"{full.get('seconds', float('nan')):7.2f} s (CPU {full.get('cpu', float('nan')):6.2f} s) "
                  f"{full.get('codes')}")
    print("target: 1000 constraints <= 5 s, about linear (default budget: 4 CPU seconds of questions per file)")


def _sources(args: argparse.Namespace) -> list[str]:
    """The bundled sets, then the Greta sets of ``--greta-sets`` if given."""
    from mse.resources import bundled_names

    sources = list(bundled_names())
    if args.greta_sets:
        sources += [str(p) for p in sorted(Path(args.greta_sets).glob("*.xml"))]
    return sources


def section_fidelity(args: argparse.Namespace, base: Path | None) -> None:
    print(f"\n## fidelity at 10 s: per signal, occurrences per timeline and mean relative start "
          f"(load {load_average()})")
    runs = 60 if args.quick else 300
    sources = _sources(args)
    worst: dict[str, list[float]] = {"rate": [], "start": []}
    for source in sources:
        cpsat = measure("fidelity", source=source, solver_name="cpsat", runs=runs, duration=10.0)
        greedy = measure("fidelity", source=source, solver_name="greedy", runs=runs, duration=10.0)
        target = measure("prior", source=source, draws=40 * runs, duration=10.0)
        accepted = target.get("accepted", 0)
        label = Path(source).stem
        print(f"{label}: target from {accepted} accepted prior draws of {target.get('draws')}; "
              f"cpsat failures {cpsat.get('failures')}, greedy failures {greedy.get('failures')}")
        print(f"   {'signal':24s} {'target':>13s} {'cpsat':>13s} {'greedy(main)':>13s}")
        for signal, (rate, start) in cpsat.get("table", {}).items():
            t = target.get("table", {}).get(signal, [float("nan"), float("nan")])
            g = greedy.get("table", {}).get(signal, [float("nan"), float("nan")])
            print(f"   {signal:24s} {t[0]:5.2f} {t[1]:6.2f}  {rate:5.2f} {start:6.2f}  {g[0]:5.2f} {g[1]:6.2f}")
            if accepted >= 200:
                worst["rate"].append(abs(rate - t[0]))
                if not math.isnan(start) and not math.isnan(t[1]):
                    worst["start"].append(abs(start - t[1]))
    if worst["rate"]:
        print(f"cpsat vs target (sets with >= 200 accepted draws): occurrence rate |diff| p50 "
              f"{statistics.median(worst['rate']):.3f} max {max(worst['rate']):.3f}; mean relative start |diff| "
              f"p50 {statistics.median(worst['start']):.3f} max {max(worst['start']):.3f}")


def section_controls(args: argparse.Namespace, base: Path | None) -> None:
    print(f"\n## controls at 10 s: --mode constraint-less must violate a constraint; a signal whose "
          f"probabilities are both 0 must never occur (load {load_average()})")
    runs = 20 if args.quick else 100
    sources = _sources(args)
    print(f"{'set':24s} {'solver':7s} {'violating':>10s} {'0/0 shown':>10s}")
    for solver_name in ("cpsat", "greedy"):
        totals = [0, 0, 0, 0]
        for source in sources:
            got = measure("controls", source=source, solver_name=solver_name, runs=runs, duration=10.0)
            if "error" in got:
                print(f"{Path(source).stem:24s} {solver_name:7s} {got['error']}")
                continue
            totals = [totals[0] + got["violating"], totals[1] + got["runs"] - got["failures"],
                      totals[2] + got["zero_shown"], totals[3] + got["zero_timelines"]]
            note = " (no constraint)" if not got["constraints"] else ""
            print(f"{Path(source).stem:24s} {solver_name:7s} {got['violating']:4d}/{got['runs'] - got['failures']:<5d} "
                  f"{got['zero_shown']:4d}/{got['zero_timelines']:<5d}{note}")
        print(f"{'all':24s} {solver_name:7s} {totals[0]:4d}/{totals[1]:<5d} {totals[2]:4d}/{totals[3]:<5d}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sections", default=",".join(SECTIONS))
    add_argument(parser)
    parser.add_argument("--quick", action="store_true")
    shared = Path(os.environ.get("MSE_SHARED", REPO.parent / "shared"))
    parser.add_argument("--greta-sets", help="folder of imported Greta sets (mse import-greta ... -o DIR)")
    args = parser.parse_args()
    imported: Path | None = None
    if args.greta_sets is None and (shared / "greta" / "lexicon.xml").is_file():
        folder = imported = Path(tempfile.mkdtemp(prefix="mse-greta-"))
        subprocess.run([sys.executable, "-m", "mse", "import-greta", str(shared / "greta" / "lexicon.xml"),
                        str(shared / "greta" / "constraint.xml"), "-o", str(folder)], capture_output=True, check=False)
        args.greta_sets = str(folder)
    print(f"mse CP-SAT bench; baseline {describe(args.baseline)}; load {load_average()}; cpus {os.cpu_count()}")
    try:
        with baseline_tree(args.baseline) as base:
            for name in args.sections.split(","):
                globals()[f"section_{name.strip()}"](args, base)
    finally:
        if imported is not None:
            shutil.rmtree(imported, ignore_errors=True)


if __name__ == "__main__":
    main()

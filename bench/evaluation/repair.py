"""`mse repair` on generated proposals (issue 33): correctness, optimality and latency.

For every bundled set and every set imported from Greta's data (``$MSE_SHARED/greta``), COUNT
proposals of a 10 s timeline are made from consistent timelines (sampled with the default
sampler) by shifting and stretching occurrences, dropping some, duplicating some, swapping the
times of two, and adding foreign ones (names the set does not know).  Each is repaired in
process with ``mse.repair`` from its ``mse-proposal/1`` form, and the result must be

* consistent under ``mse.ir.evaluate`` and under an independent checker written from
  docs/semantics.md (tests/independent_checker.py),
* proved optimal by CP-SAT (``Repair.optimal``),
* and, for the unperturbed timelines, returned unchanged (the very timeline given).

Latency is the wall time of ``mse.repair`` in process, printed as p50 / p99 / max per set and
overall, with the ratio to a baseline measured in the same run: one ``mse.sample(...,
solver="cpsat")`` of the same set and length.

    python -m bench.evaluation.repair                 # 1,000 proposals per set
    python -m bench.evaluation.repair --count 100 --sets anger relief
"""

from __future__ import annotations

import argparse
import os
import random
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

import mse
from mse.ir.evaluate import check_schedule
from mse.resources import bundled_names
from tests.independent_checker import problems

DURATION = 10.0


def proposal_from(timeline: mse.Timeline, rng: random.Random) -> dict[str, Any]:
    """A perturbed copy of a consistent timeline, as an mse-proposal/1 document."""
    ticks = round(timeline.duration * 1000)
    items = [[s.id, round(s.start * 1000), round(s.stop * 1000)] for s in timeline.signals]
    out: list[list[Any]] = []
    for name, start, stop in items:
        if rng.random() < 0.12:  # dropped
            continue
        length = stop - start
        if rng.random() < 0.5:  # shifted
            start += rng.randint(-1500, 1500)
        if rng.random() < 0.3:  # stretched
            length = max(1, round(length * rng.uniform(0.5, 1.6)))
        start = min(max(0, start), ticks - 1)
        out.append([name, start, start + length])
        if rng.random() < 0.08:  # duplicated elsewhere
            at = rng.randint(0, max(0, ticks - length))
            out.append([name, at, at + length])
    if len(out) >= 2 and rng.random() < 0.3:  # two occurrences swap their times
        i, j = rng.sample(range(len(out)), 2)
        out[i][1:], out[j][1:] = out[j][1:], out[i][1:]
    for number in range(rng.choice((0, 0, 1, 2))):  # foreign occurrences
        at = rng.randint(0, ticks - 500)
        out.append([f"foreign_{number}", at, at + rng.randint(200, 2000)])
    # Occurrences of one signal must not overlap in a valid proposal: keep the first of each clash.
    out.sort(key=lambda item: (item[1], item[0]))
    kept: list[list[Any]] = []
    last_stop: dict[str, int] = {}
    for name, start, stop in out:
        if start < last_stop.get(name, -1):
            continue
        kept.append([name, start, stop])
        last_stop[name] = stop
    rng.shuffle(kept)
    return {"format": "mse-proposal/1", "duration": timeline.duration,
            "occurrences": [{"signal": n, "start": a / 1000, "stop": b / 1000} for n, a, b in kept]}


def bench_set(name: str, model: mse.Model, count: int, seed: int) -> dict[str, Any]:
    rng = random.Random(f"{seed}/{name}")
    times: list[float] = []
    failures: list[str] = []
    optimal = unchanged_ok = consistent = 0
    changes = 0
    for index, timeline in enumerate(mse.iter_timelines(model, DURATION, seed=seed, count=count)):
        if index < 20:  # a consistent proposal comes back as it is
            same = mse.repair(model, timeline)
            unchanged_ok += same.unchanged and same.timeline is timeline
        proposal = proposal_from(timeline, rng)
        began = time.perf_counter()
        try:
            result = mse.repair(model, proposal)
        except mse.MseError as error:
            failures.append(f"{name} #{index}: {error}")
            continue
        times.append(time.perf_counter() - began)
        schedule = result.timeline.to_schedule()
        occurrences = [(o.signal, o.start, o.stop) for o in schedule.occurrences]
        ours, theirs = check_schedule(model, schedule), problems(model, occurrences, schedule.duration)
        if ours or theirs:
            failures.append(f"{name} #{index}: {[v.message for v in ours]} {theirs}")
        else:
            consistent += 1
        optimal += result.optimal
        changes += result.count("dropped") + result.count("added")
    began = time.perf_counter()
    for baseline_seed in range(5):
        mse.sample(model, DURATION, seed=baseline_seed, solver="cpsat")
    baseline = (time.perf_counter() - began) / 5
    return {"set": name, "count": count, "times": times, "consistent": consistent, "optimal": optimal,
            "unchanged": unchanged_ok, "unchanged_of": min(20, count), "changes": changes,
            "baseline": baseline, "failures": failures}


def _ms(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return 1000 * ordered[min(len(ordered) - 1, int(q * len(ordered)))] if ordered else float("nan")


def sets(chosen: list[str] | None, folder: Path) -> list[tuple[str, mse.Model]]:
    found = [(name, mse.load(name)) for name in bundled_names()]
    greta = Path(os.environ.get("MSE_SHARED", Path(__file__).resolve().parents[3] / "shared")) / "greta"
    if (greta / "lexicon.xml").is_file():
        import contextlib
        import io

        from mse.cli import main

        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            code = main(["import-greta", str(greta / "lexicon.xml"), str(greta / "constraint.xml"), "-o", str(folder)])
        if code == 0:
            found += [(f"greta/{path.stem}", mse.load(path)) for path in sorted(folder.glob("*.xml"))]
    return [(n, m) for n, m in found if not chosen or n in chosen or n.split("/")[-1] in chosen]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--count", type=int, default=1000, help="proposals per set (default 1000)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--sets", nargs="*", help="only these sets (bundled names, or greta/NAME)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as folder:
        chosen = sets(args.sets, Path(folder))
        print(f"{'set':24} {'n':>5} {'consistent':>10} {'optimal':>8} {'unchanged':>9} {'changes':>7} "
              f"{'p50 ms':>7} {'p99 ms':>7} {'max ms':>7} {'cpsat sample ms':>15} {'p50 ratio':>9}")
        everything: list[float] = []
        failed = False
        for name, model in chosen:
            row = bench_set(name, model, args.count, args.seed)
            everything += row["times"]
            ratio = _ms(row["times"], 0.5) / (1000 * row["baseline"])
            print(f"{name:24} {row['count']:5d} {row['consistent']:10d} {row['optimal']:8d} "
                  f"{row['unchanged']:>4d}/{row['unchanged_of']:<4d} {row['changes']:7d} "
                  f"{_ms(row['times'], 0.5):7.1f} {_ms(row['times'], 0.99):7.1f} {_ms(row['times'], 1.0):7.0f} "
                  f"{1000 * row['baseline']:15.1f} {ratio:9.2f}", flush=True)
            for failure in row["failures"][:5]:
                print("  FAIL", failure)
            failed |= bool(row["failures"]) or row["optimal"] < row["count"] or row["unchanged"] < row["unchanged_of"]
        print(f"all: {len(everything)} repairs, p50 {_ms(everything, 0.5):.1f} ms, p99 {_ms(everything, 0.99):.1f} ms, "
              f"max {_ms(everything, 1.0):.0f} ms (targets: p50 <= 50, p99 <= 500); "
              f"mean over the run {statistics.fmean(everything) * 1000:.1f} ms")
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())

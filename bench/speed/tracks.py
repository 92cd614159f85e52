"""Benchmark of the track formats (docs/tracks.md, issue 30).  Prints numbers; asserts nothing.

    python -m bench.speed.tracks                  # speed, then every set x 20 seeds through Greta
    python -m bench.speed.tracks --seeds 5 --no-greta

- speed: 10 s of tracks at 30 fps (301 frames) written in each format, in process (sampling the
  face player's curves included), median of ``--runs`` runs, against the timeline JSON
  (``Timeline.dumps``) of the same timeline measured in the same run; target <= 100 ms per format;
- readers: every bundled set and every set `mse import-greta` makes of $MSE_SHARED/greta (default
  ../shared), ``--seeds`` seeds each, 10 s: each OpenFace CSV through Greta's own OpenFace 2.0
  reader (tests/test_tracks_greta.py: rows rejected, values that differ from ours), and the
  timing and rest checks of tests/test_tracks.py on every timeline.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from mse.api import load, loads
from mse.dialogue import Session
from mse.export import BINARY_FORMATS, render, render_bytes
from mse.export.tracks.model import sample as sample_tracks
from mse.ir import model as ir
from mse.resources import bundled_names
from mse.sampling import sample
from mse.timeline import Timeline
from tests.test_tracks import assert_faithful
from tests.test_tracks_greta import greta_differences

REPO = Path(__file__).resolve().parents[2]
SHARED = Path(os.environ.get("MSE_SHARED", REPO.parent / "shared"))
FORMATS = ("openface", "arkit", "arkit-json", "vrma")


def write(timeline: Timeline, fmt: str) -> object:
    return render_bytes(timeline, fmt) if fmt in BINARY_FORMATS else render(timeline, fmt)


def median_ms(work: Callable[[], object], runs: int) -> float:
    times = []
    for _ in range(runs):
        begin = time.perf_counter()
        work()
        times.append(time.perf_counter() - begin)
    return 1000.0 * statistics.median(times)


def dialogue() -> Timeline:
    session = Session(seed=1)
    session.emotion(0.0, "anger", until=4.0)
    session.emotion(4.0, "relief", 0.6)
    session.end(10.0)
    return session.timeline()


def speed(runs: int) -> None:
    timelines = {
        "embarrassment": sample(load("embarrassment"), 10.0, seed=1),
        "dialogue": dialogue(),
    }
    print(f"speed: 10 s at 30 fps, median of {runs} runs (ms); baseline: the timeline JSON")
    print("(curves: the track model alone, shared by every format)")
    print(f"{'timeline':<14} {'json':>7} {'curves':>7} " + " ".join(f"{f:>11}" for f in FORMATS) + "  ratio to json")
    for name, timeline in timelines.items():
        for fmt in FORMATS:
            write(timeline, fmt)  # import the exporter before timing
        baseline = median_ms(lambda t=timeline: t.dumps(), runs)
        curves = median_ms(lambda t=timeline: sample_tracks(t), runs)
        measured = [median_ms(lambda t=timeline, f=fmt: write(t, f), runs) for fmt in FORMATS]
        ratios = " ".join(f"{m / baseline:.1f}x" for m in measured)
        print(f"{name:<14} {baseline:7.2f} {curves:7.2f} " + " ".join(f"{m:11.2f}" for m in measured) + f"  {ratios}")


def sets() -> dict[str, ir.Model]:
    models = {name: load(name) for name in bundled_names()}
    greta = SHARED / "greta"
    if (greta / "lexicon.xml").exists():
        from mse.syntax.greta import import_greta

        for expression in import_greta(greta / "lexicon.xml", greta / "constraint.xml"):
            models[f"greta:{expression.name}"] = loads(expression.xml, path=f"{expression.name}.xml")
    return models


def readers(seeds: int, with_greta: bool) -> None:
    print(f"\nreaders: every set x {seeds} seeds, 10 s" + ("" if with_greta else " (Greta skipped)"))
    print(f"{'set':<28} {'files':>5} {'rows':>6} {'rejected':>8} {'differ':>6} {'faithful':>8}")
    totals = [0, 0, 0, 0, 0]
    with tempfile.TemporaryDirectory() as folder:
        for name, model in sets().items():
            files = rows = rejected = differ = unfaithful = 0
            for seed in range(1, seeds + 1):
                timeline = sample(model, 10.0, seed=seed)
                try:
                    assert_faithful(timeline)
                except AssertionError:
                    unfaithful += 1
                files += 1
                if with_greta:
                    read, problems = greta_differences(timeline, SHARED, Path(folder))
                    rows += len(read.rows)
                    rejected += read.rejected
                    differ += len(problems)
            for i, value in enumerate((files, rows, rejected, differ, unfaithful)):
                totals[i] += value
            print(f"{name:<28} {files:5d} {rows:6d} {rejected:8d} {differ:6d} {files - unfaithful:5d}/{files}")
    files, rows, rejected, differ, unfaithful = totals
    print(f"{'total':<28} {files:5d} {rows:6d} {rejected:8d} {differ:6d} {files - unfaithful:5d}/{files}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--runs", type=int, default=30)
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--no-greta", action="store_true", help="skip Greta's reader (no Java)")
    parser.add_argument("--speed-only", action="store_true")
    args = parser.parse_args(argv)
    print(f"load average: {os.getloadavg()[0]:.2f}")
    speed(args.runs)
    if not args.speed_only:
        readers(args.seeds, not args.no_greta)
    print(f"load average: {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

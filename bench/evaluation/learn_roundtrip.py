"""Learn → sample round trip of ``mse learn`` (docs/learn.md, "Measured"; issue 32).

For each of ``--sets`` random sets (``bench/generators/corpus.py``: ``random_model`` with
``--signals`` signals and a seeded number of constraints between n/2 and 2n; sets the default
sampler cannot sample at ``--duration`` are skipped and counted), sample ``--count`` timelines
(the corpus), learn a set from them at ``--confidence`` (default 1), sample ``--back``
timelines of the learned set with the default sampler and compare each signal's
**occurrence rate** (the fraction of timelines where it occurs) between the two.

Three unrelated seed ranges: the corpus is made with seeds ``S .. S+count-1``, the learner
calibrates with ``S + 2·10⁶`` and the learned set is sampled back with ``S + 10⁶``.  (A
learner calibrating on the corpus' own seeds draws the same random numbers as the corpus
did: its samples share the corpus' sampling noise, and it calibrates to the noise.)

The baseline, measured in the same run: the generating set itself sampled back with the
same seeds (``truth`` column): the difference two samples of one set show by chance.  With
``--back`` 1,000 rather than 300 the learned set's rate is measured more precisely (the
corpus keeps its ``--count`` timelines, and its own sampling error).

Printed per set: learning time, learned constraints, calibration rounds run, the largest
rate difference (signal, corpus → learned), the truth's largest difference, the signals off
by more than ``--tolerance`` (0.1); then totals.  ``--no-calibrate`` measures the raw
estimates (the "before").

    python -m bench.evaluation.learn_roundtrip --sets 24
"""

from __future__ import annotations

import argparse
import json
import random
import statistics
import time
from collections import Counter
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import mse.sampling as sampling
from bench.generators.corpus import random_model
from mse.diagnostics import MseError
from mse.ir import model as ir
from mse.learn import LearnOptions, learn_corpus
from mse.learn.corpus import Corpus
from mse.learn.read import read_timeline_sequences
from mse.timeline import Timeline, dumps_jsonl


def occurrence_rates(timelines: Sequence[Timeline]) -> dict[str, float]:
    present: Counter[str] = Counter()
    for timeline in timelines:
        present.update({signal.id for signal in timeline.signals})
    return {signal: count / len(timelines) for signal, count in present.items()}


def starts_per_timeline(timelines: Sequence[Timeline]) -> dict[str, float]:
    starts: Counter[str] = Counter()
    for timeline in timelines:
        starts.update(signal.id for signal in timeline.signals)
    return {signal: count / len(timelines) for signal, count in starts.items()}


def corpus_of(timelines: Sequence[Timeline]) -> Corpus:
    """The timelines as ``mse learn`` reads them from a ``.jsonl`` file."""
    from mse.learn.corpus import DEFAULT_MAPPING, build_corpus

    raw, _ = read_timeline_sequences(Path("corpus.jsonl"), dumps_jsonl(timelines).encode("utf-8"))
    corpus, _ = build_corpus(raw, DEFAULT_MAPPING)
    return corpus


#: Offsets of the seeds the learned set is sampled back with, and the learner calibrates
#: with, from the corpus' seed (ranges that never overlap).
BACK_SEEDS = 10**6
LEARN_SEEDS = 2 * 10**6


def round_trip(truth: ir.Model, count: int, duration: float, seed: int, options: LearnOptions,
               back_count: int | None = None) -> dict[str, Any]:
    corpus = list(sampling.iter_timelines(truth, duration, seed=seed, count=count))
    began, began_cpu = time.perf_counter(), time.process_time()
    result = learn_corpus(corpus_of(corpus), options)
    learn_s, learn_cpu_s = time.perf_counter() - began, time.process_time() - began_cpu
    back_count = back_count or count
    back = list(sampling.iter_timelines(result.model, duration, seed=seed + BACK_SEEDS, count=back_count))
    again = list(sampling.iter_timelines(truth, duration, seed=seed + BACK_SEEDS, count=back_count))
    before, after, truth_after = occurrence_rates(corpus), occurrence_rates(back), occurrence_rates(again)
    signals = sorted(set(before) | set(after))
    diffs = {s: (before.get(s, 0.0), after.get(s, 0.0)) for s in signals}
    worst = max(signals, key=lambda s: abs(diffs[s][0] - diffs[s][1]))
    # Repetitive signals (more than one start in a corpus timeline): starts per timeline, the
    # learned set's against the corpus', relative (calibration matches presence, mostly).
    repeated = {s for t in corpus for s, n in Counter(o.id for o in t.signals).items() if n > 1}
    starts_before, starts_after = starts_per_timeline(corpus), starts_per_timeline(back)
    starts_off = {s: abs(starts_after.get(s, 0.0) - starts_before[s]) / starts_before[s] for s in repeated}
    truth_diffs = {s: abs(before.get(s, 0.0) - truth_after.get(s, 0.0)) for s in set(before) | set(truth_after)}
    return {
        "set": truth.name,
        "constraints": len(truth.constraints),
        "learned_constraints": len(result.model.constraints),
        "learn_s": learn_s,
        "learn_cpu_s": learn_cpu_s,
        "rounds": sum(1 for note in result.calibration if note.startswith("round ")),
        "worst": worst,
        "worst_rates": diffs[worst],
        "max_diff": abs(diffs[worst][0] - diffs[worst][1]),
        "mean_diff": statistics.fmean(abs(a - b) for a, b in diffs.values()),
        "off": {s: ab for s, ab in diffs.items()},
        "starts_off": starts_off,
        "truth_max_diff": max(truth_diffs.values()),
        "truth_off": sorted(s for s, d in truth_diffs.items() if d > 0.1),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sets", type=int, default=24, help="random sets to measure (sampleable ones)")
    parser.add_argument("--signals", type=int, default=18)
    parser.add_argument("--count", type=int, default=300, help="timelines in the corpus")
    parser.add_argument("--back", type=int, default=1000, help="timelines of the learned set (and of the truth)")
    parser.add_argument("--duration", type=float, default=10.0)
    parser.add_argument("--confidence", type=float, default=1.0)
    parser.add_argument("--tolerance", type=float, default=0.1)
    parser.add_argument("--seed", type=int, default=0, help="first set seed")
    parser.add_argument("--no-calibrate", action="store_true")
    parser.add_argument("--json", help="write every row to this file")
    args = parser.parse_args()
    rows: list[dict[str, Any]] = []
    skipped = 0
    seed = args.seed
    print(f"{'set':10s} {'cons':>4s} {'learned':>7s} {'learn s':>7s} {'rounds':>6s} {'max diff':>8s} "
          f"{'truth':>5s}  worst; off by > "
          f"{args.tolerance:g}", flush=True)
    while len(rows) < args.sets:
        seed += 1
        constraints = random.Random(seed).randint(args.signals // 2, 2 * args.signals)
        truth = random_model(seed, args.signals, constraints, name=f"random{seed}")
        options = LearnOptions(name=truth.name, confidence=args.confidence, seed=seed + LEARN_SEEDS,
                               calibrate=not args.no_calibrate)
        try:
            row = round_trip(truth, args.count, args.duration, seed, options, args.back)
        except MseError as error:  # no timeline of the set (or of the learned set: counted too)
            skipped += 1
            print(f"{truth.name:10s} skipped: {str(error).splitlines()[0][:100]}", flush=True)
            continue
        rows.append(row)
        off = {s: ab for s, ab in row["off"].items() if abs(ab[0] - ab[1]) > args.tolerance}
        a, b = row["worst_rates"]
        print(f"{row['set']:10s} {row['constraints']:4d} {row['learned_constraints']:7d} {row['learn_s']:7.1f} "
              f"{row['rounds']:6d} {row['max_diff']:8.2f} {row['truth_max_diff']:5.2f}  "
              f"{row['worst']} {a:.2f} -> {b:.2f}; "
              + (", ".join(f"{s} {x:.2f}->{y:.2f}" for s, (x, y) in sorted(off.items())) or "-"), flush=True)
    within = sum(1 for r in rows if r["max_diff"] <= args.tolerance)
    signals = sum(len(r["off"]) for r in rows)
    off_signals = sum(1 for r in rows for x, y in r["off"].values() if abs(x - y) > args.tolerance)
    times = sorted(r["learn_s"] for r in rows)
    print(f"\n{len(rows)} sets ({skipped} skipped: not sampleable), {args.count} timelines of "
          f"{args.duration:g} s each in the corpus, {args.back} sampled back, "
          f"--confidence {args.confidence:g}{', no calibration' if args.no_calibrate else ''}")
    print(f"sets with every signal within {args.tolerance:g}: {within} / {len(rows)}; "
          f"signals off: {off_signals} / {signals}; largest difference {max(r['max_diff'] for r in rows):.2f}; "
          f"mean difference {statistics.fmean(r['mean_diff'] for r in rows):.3f}")
    truth_within = sum(1 for r in rows if r["truth_max_diff"] <= args.tolerance)
    print(f"the generating sets sampled back the same way (baseline): {truth_within} / {len(rows)} sets within "
          f"{args.tolerance:g}; signals off: {sum(len(r['truth_off']) for r in rows)}; largest difference "
          f"{max(r['truth_max_diff'] for r in rows):.2f}")
    starts = [d for r in rows for d in r["starts_off"].values()]
    if starts:
        print(f"repetitive signals' starts per timeline ({len(starts)} signals): mean relative difference "
              f"{statistics.fmean(starts):.3f}, largest {max(starts):.2f}, "
              f"above 0.2: {sum(1 for d in starts if d > 0.2)}")
    cpu = sorted(r["learn_cpu_s"] for r in rows)
    print(f"learn time: median {statistics.median(times):.1f} s, max {times[-1]:.1f} s (wall); "
          f"CPU median {statistics.median(cpu):.1f} s, max {cpu[-1]:.1f} s")
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()

"""Recovery and speed of ``mse learn`` (docs/learn.md, "Measured").

For every bundled set and every Greta set imported from ``$MSE_SHARED/greta`` (the
*ground truth*), sample N timelines, learn a set from them, and measure it against the
ground truth:

* ``gt⊨``: ground-truth constraints implied by the learned set (CP-SAT implication at the
  sampled duration; "?" when the solver could not decide within its time limit), out of
  those whose signals all occur in the corpus; ``uns``: the others (unseen signals: no
  corpus can teach them);
* ``¬gt``: learned constraints *not* implied by the ground truth;
* ``occ``: mean absolute difference of per-signal occurrence rates between the corpus and N
  timelines sampled from the learned set (max in brackets);
* ``KS``: mean two-sample Kolmogorov-Smirnov statistic of each signal's durations (corpus
  against samples of the learned set; max in brackets);
* ``order``: mean absolute difference of "a starts before b" frequencies over signal pairs
  seen together at least 10 times in both.

Speed: ``--speed N`` learns N timelines of one set and prints the time, with reading the
same corpus as the baseline measured in the same run (the ratio is what to compare).

    python -m bench.evaluation.learn --sizes 100 1000 --speed 10000
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import statistics
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path
from typing import Any

import mse.api as api
import mse.sampling as sampling
from mse.ir import model as ir
from mse.learn import LearnOptions, learn_corpus
from mse.learn.implication import ImplicationChecker
from mse.learn.read import read_corpus
from mse.timeline import Timeline, dumps_jsonl


def ground_truths(greta: bool) -> list[tuple[str, ir.Model]]:
    from mse.resources import bundled_names

    sets = [(name, api.load(name)) for name in bundled_names()]
    shared = Path(os.environ.get("MSE_SHARED", "../shared")) / "greta"
    if greta and (shared / "lexicon.xml").is_file():
        folder = Path(tempfile.mkdtemp(prefix="mse-bench-greta-"))
        from mse.cli import main

        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            main(["import-greta", str(shared / "lexicon.xml"), str(shared / "constraint.xml"), "-o", f"{folder}/"])
        for path in sorted(folder.glob("*.xml")):
            try:
                sets.append((f"greta:{path.stem}", api.load(path)))
            except Exception as error:
                print(f"greta:{path.stem}: not loadable: {error}", file=sys.stderr)
    return sets


def sample(model: ir.Model, count: int, duration: float, seed: int) -> list[Timeline]:
    return list(sampling.iter_timelines(model, duration, seed=seed, count=count))


def implied_count(premise: ir.Model, targets: list[ir.Expr], duration: int) -> Counter[str]:
    if not targets:
        return Counter()
    checker = ImplicationChecker(premise, targets, duration=duration)
    by = [c.id for c in premise.constraints]
    return Counter(checker.implied(f"extra:{n}", by) for n in range(len(targets)))


def _occurrence(timelines: list[Timeline]) -> tuple[Counter[str], dict[str, list[float]], Counter[tuple[str, str]],
                                                   Counter[tuple[str, str]]]:
    present: Counter[str] = Counter()
    lengths: dict[str, list[float]] = {}
    together: Counter[tuple[str, str]] = Counter()
    before: Counter[tuple[str, str]] = Counter()
    for timeline in timelines:
        first: dict[str, float] = {}
        for signal in timeline.signals:
            lengths.setdefault(signal.id, []).append(signal.stop - signal.start)
            first.setdefault(signal.id, signal.start)
        present.update(first.keys())
        names = sorted(first)
        for i, a in enumerate(names):
            for b in names[i + 1:]:
                together[(a, b)] += 1
                if first[a] < first[b]:
                    before[(a, b)] += 1
    return present, lengths, together, before


def compare(corpus: list[Timeline], learned: list[Timeline]) -> dict[str, float]:
    from scipy.stats import ks_2samp

    p1, l1, t1, b1 = _occurrence(corpus)
    p2, l2, t2, b2 = _occurrence(learned)
    signals = sorted(set(p1) | set(p2))
    occ = [abs(p1[s] / len(corpus) - p2[s] / len(learned)) for s in signals]
    ks = [float(ks_2samp(l1[s], l2[s]).statistic) for s in signals if len(l1.get(s, [])) >= 5
          and len(l2.get(s, [])) >= 5]
    order = [abs(b1[k] / t1[k] - b2[k] / t2[k]) for k in t1 if t1[k] >= 10 and t2[k] >= 10]
    return {
        "occurrence_mean": statistics.fmean(occ) if occ else 0.0,
        "occurrence_max": max(occ, default=0.0),
        "ks_mean": statistics.fmean(ks) if ks else float("nan"),
        "ks_max": max(ks, default=float("nan")),
        "order_mean": statistics.fmean(order) if order else float("nan"),
        "order_pairs": float(len(order)),
    }


def recovery(name: str, truth: ir.Model, count: int, duration: float, confidence: float, seed: int) -> dict[str, Any]:
    row: dict[str, Any] = {"set": name, "n": count}
    try:
        corpus = sample(truth, count, duration, seed)
    except Exception as error:
        row["error"] = f"ground truth not sampled: {type(error).__name__}"
        return row
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "corpus.jsonl"
        path.write_text(dumps_jsonl(corpus), encoding="utf-8")
        began = time.perf_counter()
        read, _ = read_corpus([path])
        result = learn_corpus(read, LearnOptions(name=name.replace(":", "_"), confidence=confidence, seed=seed))
        row["learn_s"] = time.perf_counter() - began
    ticks = round(duration * 1000)
    seen = {signal.id for timeline in corpus for signal in timeline.signals}
    # A constraint naming a signal the corpus never shows cannot be learned from it.
    learnable = [c.expr for c in truth.constraints if ir.mentioned_signals(c.expr) <= seen]
    gt = implied_count(result.model, learnable, ticks)
    spurious = implied_count(truth, [c.expr for c in result.model.constraints], ticks)
    row.update({
        "gt_constraints": len(truth.constraints),
        "gt_learnable": len(learnable),
        "gt_implied": gt["yes"], "gt_undecided": gt["unknown"],
        "learned_constraints": len(result.model.constraints),
        "learned_not_implied": spurious["no"], "learned_undecided": spurious["unknown"],
        "breaks": len(result.breaks),
        "lint": sorted({d.code for d in result.diagnostics if d.code[:2] in ("W3", "W4")}),
    })
    try:
        row.update(compare(corpus, sample(result.model, count, duration, seed + 10**6)))
    except Exception as error:
        row["error"] = f"learned set not sampled: {type(error).__name__}"
    return row


def speed(count: int, name: str, duration: float) -> dict[str, float]:
    corpus = sample(api.load(name), count, duration, 1)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "corpus.jsonl"
        path.write_text(dumps_jsonl(corpus), encoding="utf-8")
        began = time.perf_counter()
        read, _ = read_corpus([path])
        reading = time.perf_counter() - began
        began = time.perf_counter()
        learn_corpus(read, LearnOptions(name=name, confidence=1.0))
        learning = time.perf_counter() - began
    return {"sequences": count, "read_s": reading, "learn_s": learning, "total_s": reading + learning,
            "ratio": (reading + learning) / reading}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", type=int, nargs="+", default=[100, 1000])
    parser.add_argument("--sets", nargs="*", help="only these sets (bundled names or greta:NAME)")
    parser.add_argument("--no-greta", action="store_true")
    parser.add_argument("--duration", type=float, default=10.0)
    parser.add_argument("--confidence", type=float, default=1.0)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--speed", type=int, default=0, help="also time learning this many sequences")
    parser.add_argument("--speed-set", default="embarrassment")
    parser.add_argument("--json", help="write every row to this file")
    args = parser.parse_args()
    rows = []
    if args.speed:
        timing = speed(args.speed, args.speed_set, args.duration)
        print(f"speed: {timing['sequences']} {args.speed_set} sequences: read {timing['read_s']:.2f} s (baseline), "
              f"learn {timing['learn_s']:.2f} s, total {timing['total_s']:.2f} s "
              f"({timing['ratio']:.1f}x reading; target <= 30 s)", flush=True)
        rows.append({"speed": timing})
    header = (f"{'set':22s} {'N':>5s} {'learn s':>7s} {'gt⊨':>9s} {'uns':>3s} {'¬gt':>7s} {'occ (max)':>12s} "
              f"{'KS (max)':>12s} {'order':>6s} lint")
    print(header, flush=True)
    for name, truth in ground_truths(not args.no_greta):
        if args.sets and name not in args.sets:
            continue
        for count in args.sizes:
            row = recovery(name, truth, count, args.duration, args.confidence, args.seed)
            rows.append(row)
            if "gt_implied" not in row:
                print(f"{name:22s} {count:5d}  {row.get('error')}", flush=True)
                continue
            undecided = f"+{row['gt_undecided']}?" if row["gt_undecided"] else ""
            spurious = f"+{row['learned_undecided']}?" if row["learned_undecided"] else ""
            print(f"{name:22s} {count:5d} {row['learn_s']:7.1f} "
                  f"{row['gt_implied']:>3d}/{row['gt_learnable']:<3d}{undecided:>3s} "
                  f"{row['gt_constraints'] - row['gt_learnable']:>3d} "
                  f"{row['learned_not_implied']:>3d}/{row['learned_constraints']:<3d}{spurious} "
                  f"{row.get('occurrence_mean', float('nan')):5.3f} ({row.get('occurrence_max', float('nan')):.2f}) "
                  f"{row.get('ks_mean', float('nan')):5.3f} ({row.get('ks_max', float('nan')):.2f}) "
                  f"{row.get('order_mean', float('nan')):6.3f} {','.join(row['lint']) or '-'}"
                  + (f"  {row['error']}" if "error" in row else ""), flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()

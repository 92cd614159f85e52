"""Per-call overhead of the Python API: a loop of ``mse.sample(model, 10, seed=n)`` against
``mse.iter_timelines(model, 10, seed=0, count=N)`` (the same N timelines), measured in the
same run: many short rounds, the two interleaved (and in alternating order) so that the
machine's load weighs on both alike; the ratio is the median of the rounds' ratios.

Target: the loop runs within 10 % of ``iter_timelines``' rate (ratio >= 0.90).  Both give
the same timelines (checked here).

    python -m bench.speed.api_overhead [--sets anger,relief,embarrassment] [--count 50] [--rounds 21]
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import mse


def loop_rate(model: mse.Model, count: int) -> float:
    began = time.process_time()
    for seed in range(count):
        mse.sample(model, 10.0, seed=seed)
    return count / (time.process_time() - began)


def iter_rate(model: mse.Model, count: int) -> float:
    began = time.process_time()
    for _ in mse.iter_timelines(model, 10.0, seed=0, count=count):
        pass
    return count / (time.process_time() - began)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sets", default="anger,relief,embarrassment")
    parser.add_argument("--count", type=int, default=50, help="timelines per round and way")
    parser.add_argument("--rounds", type=int, default=21, help="interleaved rounds (medians reported)")
    args = parser.parse_args()
    print(f"{'set':16s} {'sample loop/s':>14s} {'iter_timelines/s':>17s} {'ratio':>6s}")
    worst = 1.0
    for name in args.sets.split(","):
        model = mse.load(name)
        alone = [mse.sample(model, 10.0, seed=seed) for seed in range(5)]
        assert alone == list(mse.iter_timelines(model, 10.0, seed=0, count=5)), "the loop and the iterator differ"
        iter_rate(model, 10)  # warm-up: imports, the per-model plan
        loops, iters, ratios = [], [], []
        for index in range(args.rounds):
            if index % 2:
                loops.append(loop_rate(model, args.count))
                iters.append(iter_rate(model, args.count))
            else:
                iters.append(iter_rate(model, args.count))
                loops.append(loop_rate(model, args.count))
            ratios.append(loops[-1] / iters[-1])
        loop, whole, ratio = statistics.median(loops), statistics.median(iters), statistics.median(ratios)
        worst = min(worst, ratio)
        print(f"{name:16s} {loop:14.0f} {whole:17.0f} {ratio:6.2f}", flush=True)
    print(f"worst ratio {worst:.2f} (target >= 0.90); CPU time, {args.rounds} rounds of {args.count} timelines "
          f"each way; load average {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

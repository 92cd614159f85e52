"""One cell of the distribution bench (a set at a duration) with standard errors: noise or bias?

    python -m bench.evaluation.cell greta:tension 10 --count 400 --chains 40 --sweeps 0 10 30 60 120
    python -m bench.evaluation.cell greta:embarrassment 60 --count 400 --wanted 4000 --draws 3000000

``bench.evaluation.distribution`` says whether a cell is within its target (mean once-only
signals per timeline within 0.2 of the reference, every rate within 0.1) from 100 timelines
per sampler; a repetitive signal's rate then has a standard error near 0.1 by itself, so a
cell "off by 0.11" says nothing.  This script measures one cell with as many timelines as asked
and gives every number its standard error:

* the reference: rejection (consistent prior draws: independent, binomial or sample errors)
  when at least ``--min-accepted`` of ``--draws`` are consistent, otherwise the target's chain
  (:func:`mse.solve.chain.chain_samples`): ``--chains`` chains from different walks, each
  ``--burn`` sweeps then ``--per-chain`` timelines ``--thin`` sweeps apart; the kept timelines
  of one chain are correlated, so the error is that of the chains' means (batch means);
* each sampler (``--solvers``; seeds 0..N-1 as the bench): its difference from the reference
  and the difference's standard error, the CPU per timeline (p50, p99);
* with ``--sweeps``, where the sampler chains (``walk+chain``, ``cpsat+chain``): its start
  (the walk's timeline, CP-SAT's) followed by 0, 10, ... sweeps with the seed's own chain
  stream, which after the chain's own number (:meth:`mse.solve.chain.Chain.sweeps`) is the
  sampler's timeline: how fast the chain forgets the start, so whether the fixed number of
  sweeps leaves a bias.

Rates as in :mod:`bench.evaluation.reference`: a once-only signal's fraction of timelines, a
repetitive one's occurrences per 10 s.  Every timeline is re-checked by the one evaluator.
"""

from __future__ import annotations

import argparse
import math
import os
import random
import statistics as stats
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from bench.evaluation.distribution import ONCE_TOLERANCE, RATE_TOLERANCE, checked, greta_sets
from bench.evaluation.reference import RATE_SECONDS, sample_reference
from mse.api import load
from mse.diagnostics import MseError
from mse.ir import model as ir
from mse.ir.schedule import Schedule, to_ticks
from mse.solve.chain import chain_for, chain_samples
from mse.solve.protocol import SolveRequest, get_solver

ONCE = "once-only / timeline"


@dataclass(frozen=True)
class Sample:
    """Timelines of one sampler (or the reference) and, per timeline, its group: the chain it
    comes from (correlated timelines) or its own index (independent ones)."""

    label: str
    schedules: tuple[Schedule, ...]
    groups: tuple[int, ...]
    cpu: tuple[float, ...] = ()


def values(model: ir.Model, schedules: Sequence[Schedule], duration: float, name: str) -> list[float]:
    """Per timeline: its once-only signals (``name == ONCE``), whether the once-only signal
    ``name`` occurs, or the repetitive signal's occurrences per RATE_SECONDS."""
    repetitive = {s.id for s in model.signals if s.repetitive}
    found: list[float] = []
    for schedule in schedules:
        counts: dict[str, int] = {}
        for occurrence in schedule.occurrences:
            counts[occurrence.signal] = counts.get(occurrence.signal, 0) + 1
        if name == ONCE:
            found.append(float(sum(1 for s in counts if s not in repetitive)))
        elif name in repetitive:
            found.append(counts.get(name, 0) * RATE_SECONDS / duration)
        else:
            found.append(1.0 if name in counts else 0.0)
    return found


def mean_and_error(sample: Sample, data: list[float]) -> tuple[float, float]:
    """Mean and its standard error, from the groups' means (independent timelines: one group
    each, the usual sd / sqrt(n); for a 0/1 value the binomial error)."""
    mean = sum(data) / len(data)
    by_group: dict[int, list[float]] = {}
    for group, value in zip(sample.groups, data, strict=True):
        by_group.setdefault(group, []).append(value)
    means = [sum(v) / len(v) for v in by_group.values()]
    if len(means) < 2:
        return mean, math.nan
    return mean, stats.stdev(means) / math.sqrt(len(means))


def reference(model: ir.Model, duration: float, args: argparse.Namespace) -> tuple[Sample, str]:
    drawn = sample_reference(model, duration, wanted=args.wanted, seed=args.reference_seed,
                             max_draws=0 if args.reference == "chain" else args.draws)
    if args.reference != "chain" and len(drawn.accepted) >= args.min_accepted:
        count = len(drawn.accepted)
        return (Sample("reference", drawn.accepted, tuple(range(count))),
                f"rejection, {count} of {drawn.draws} prior draws consistent ({drawn.acceptance:.2%})")
    first = args.reference_seed
    kept, _ = chain_samples(model, duration, args.chains * args.per_chain, seed=first, chains=args.chains,
                            burn=args.burn, thin=args.thin)
    groups = tuple(index // args.per_chain for index in range(len(kept)))
    return (Sample("reference", tuple(kept), groups),
            f"chain: {args.chains} chains from the walks of seeds {first}..{first + args.chains - 1}, "
            f"{args.burn} sweeps of burn-in, "
            f"then {args.per_chain} timelines {args.thin} sweeps apart ({len(kept)})"
            + (f"; rejection: {len(drawn.accepted)} of {drawn.draws} draws consistent" if drawn.draws else ""))


def sampler(model: ir.Model, duration: float, solver: str, count: int) -> tuple[Sample, str]:
    backend = get_solver(solver)
    schedules: list[Schedule] = []
    cpu: list[float] = []
    methods: dict[str, int] = {}
    for seed in range(count):
        began = time.process_time()
        solution = backend.solve(model, SolveRequest(duration=duration, seed=seed)).solutions[0]
        cpu.append(time.process_time() - began)
        method = solution.method or solver
        methods[method] = methods.get(method, 0) + 1
        schedules.append(checked(model, solution.schedule, solver, seed))
    made = ", ".join(f"{k} {v}" for k, v in sorted(methods.items()))
    return Sample(solver, tuple(schedules), tuple(range(count)), tuple(cpu)), made


def from_starts(model: ir.Model, duration: float, solver: str, count: int, sweeps: Sequence[int]) -> list[Sample]:
    """The chain from ``solver``'s start (the walk's timeline, CP-SAT's) after each number of
    ``sweeps``, with the seed's own chain stream (``random.Random("chain/S")``, as
    :func:`mse.solve.chain.chained`)."""
    def request_of(seed: int) -> SolveRequest:
        return SolveRequest(duration=duration, seed=seed, rejection=False)

    if solver == "cpsat":
        from mse.solve.cpsat.solver import solve_one

        def start(seed: int) -> Schedule:
            return solve_one(model, request_of(seed), seed, [])
    else:
        walker = get_solver(solver)

        def start(seed: int) -> Schedule:
            return walker.solve(model, request_of(seed)).solutions[0].schedule
    found: dict[int, list[Schedule]] = {n: [] for n in sweeps}
    cpu: dict[int, list[float]] = {n: [] for n in sweeps}
    chain = chain_for(model, to_ticks(duration))
    for seed in range(count):
        first = start(seed)
        for n in sweeps:
            began = time.process_time()
            made = chain.run(first, random.Random(f"chain/{seed}"), n) if n else first
            cpu[n].append(time.process_time() - began)
            found[n].append(checked(model, made, f"{solver} start + {n} sweeps", seed))
    name = "walk" if solver != "cpsat" else "CP-SAT"
    return [Sample(f"{name}'s start + {n} sweeps" if n else f"{name}'s start", tuple(found[n]),
                   tuple(range(count)), tuple(cpu[n])) for n in sweeps]


def percentile(data: Sequence[float], share: float) -> float:
    ordered = sorted(data)
    return ordered[min(len(ordered) - 1, int(share * len(ordered)))]


def table(model: ir.Model, duration: float, wanted: Sample, samples: Sequence[Sample]) -> list[str]:
    """Rows: once-only signals per timeline, each signal's rate, the worst rate error; columns:
    the reference (mean ± standard error), each sample's difference from it (± the difference's
    standard error)."""
    names = [ONCE, *(s.id for s in model.signals)]
    lines = ["| | reference | " + " | ".join(s.label for s in samples) + " |",
             "|---|---|" + "---|" * len(samples)]
    worst: dict[str, tuple[float, float, str]] = {s.label: (0.0, 0.0, "-") for s in samples}
    for name in names:
        target, error = mean_and_error(wanted, values(model, wanted.schedules, duration, name))
        label = name if name == ONCE or not model.signal(name).repetitive else f"{name} (per 10 s)"
        cells = [label, f"{target:.3f} ± {error:.3f}"]
        for sample in samples:
            mine, own = mean_and_error(sample, values(model, sample.schedules, duration, name))
            difference, combined = mine - target, math.hypot(own, error)
            tolerance = ONCE_TOLERANCE if name == ONCE else RATE_TOLERANCE
            mark = " ✗" if round(abs(difference), 3) > tolerance else ""
            cells.append(f"{difference:+.3f} ± {combined:.3f}{mark}")
            if name != ONCE and abs(difference) > worst[sample.label][0]:
                worst[sample.label] = (abs(difference), combined, name)
        lines.append("| " + " | ".join(cells) + " |")
    lines.append("| largest rate error (signal) | | " + " | ".join(
        f"{worst[s.label][0]:.3f} ± {worst[s.label][1]:.3f} ({worst[s.label][2]})" for s in samples) + " |")
    lines.append("| CPU per timeline p50 / p99 (ms) | | " + " | ".join(
        f"{1000 * percentile(s.cpu, 0.5):.0f} / {1000 * percentile(s.cpu, 0.99):.0f}" if s.cpu else "-"
        for s in samples) + " |")
    return lines


def model_of(name: str) -> ir.Model:
    if name.startswith("greta:"):
        with tempfile.TemporaryDirectory() as directory:
            found = greta_sets(Path(directory))
        if name not in found:
            raise SystemExit(f"{name}: no such Greta set (Greta's: {', '.join(found)})")
        return found[name]
    try:
        return load(name)
    except MseError as error:  # its file:line:col message and a non-zero exit, not a traceback
        raise SystemExit(str(error)) from None


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("set", help="a bundled set, greta:NAME or a file")
    parser.add_argument("duration", type=float, help="seconds")
    parser.add_argument("--count", type=int, default=400, help="timelines per sampler (seeds 0..N-1)")
    parser.add_argument("--solvers", nargs="*", default=["greedy", "cpsat"])
    parser.add_argument("--sweeps", nargs="*", type=int, default=[],
                        help="also the chain from each sampler's start after these many sweeps")
    parser.add_argument("--reference", choices=["auto", "chain"], default="auto",
                        help="auto: rejection where it accepts enough draws, else the chain; chain: the chain")
    parser.add_argument("--reference-seed", type=int, default=1,
                        help="the reference's seed (rejection's stream; the chains' first walk and streams)")
    parser.add_argument("--wanted", type=int, default=4000, help="rejection: consistent draws wanted")
    parser.add_argument("--draws", type=int, default=1_000_000, help="rejection: prior draws at most")
    parser.add_argument("--min-accepted", type=int, default=1000, help="rejection is the reference from this many")
    parser.add_argument("--chains", type=int, default=40, help="chain reference: independent chains")
    parser.add_argument("--per-chain", type=int, default=50, help="chain reference: timelines kept per chain")
    parser.add_argument("--burn", type=int, default=100, help="chain reference: sweeps dropped")
    parser.add_argument("--thin", type=int, default=10, help="chain reference: sweeps between kept timelines")
    args = parser.parse_args(argv)
    model = model_of(args.set)
    began = time.monotonic()
    wanted, how = reference(model, args.duration, args)
    print(f"reference ({time.monotonic() - began:.0f} s): {how}", flush=True)
    samples: list[Sample] = []
    for solver in args.solvers:
        began = time.monotonic()
        sample, made = sampler(model, args.duration, solver, args.count)
        samples.append(sample)
        print(f"{solver} ({time.monotonic() - began:.0f} s): {made}", flush=True)
    for solver in args.solvers if args.sweeps else ():
        samples.extend(from_starts(model, args.duration, solver, args.count, args.sweeps))
    load_average = os.getloadavg()[0]
    sweeps = chain_for(model, to_ticks(args.duration)).sweeps()
    print()
    print(f"**{args.set}, {args.duration:g} s**: reference {how}; {args.count} timelines per sampler "
          f"(seeds 0..{args.count - 1}); sampler columns: difference from the reference ± its standard "
          f"error; ✗ beyond the target ({ONCE_TOLERANCE} once-only, {RATE_TOLERANCE} a rate), whatever "
          f"the error; the samplers' chain runs {sweeps} sweeps here.  Load average {load_average:.1f}.")
    print()
    print("\n".join(table(model, args.duration, wanted, samples)))
    return 0


if __name__ == "__main__":
    sys.exit(main())

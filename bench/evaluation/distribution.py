"""Do the samplers draw the distribution the author wrote?  (issue 32)

    python -m bench.evaluation.distribution                      # every set, 10 s, 60 s, 3,600 s
    python -m bench.evaluation.distribution --sets panic_fear greta:panic_fear --durations 3600
    python -m bench.evaluation.distribution --markdown bench/results/distribution.md

For every bundled set and every Greta set (imported from ``$MSE_SHARED/greta`` with
``mse import-greta`` into a temporary directory) and every duration, it samples timelines with
the default sampler (``greedy``: the walk, CP-SAT when it gives up) and with CP-SAT, and
compares them with the *reference*: the prior conditioned on consistency, by rejection
(bench/evaluation/reference.py).  Per set and duration: the mean number of once-only signals
per timeline, and per signal its rate (once-only: fraction of timelines; repetitive:
occurrences per 10 s).  Targets: mean once-only signals within 0.2 of the reference, every
rate within 0.1.  Every timeline is re-checked by the one evaluator (an inconsistent one is an
error, not a statistic).

Where rejection is impractical (fewer than ``--min-accepted`` consistent draws within the
budget), the reference of that duration is the target's Markov chain (mse/solve/chain.py,
:func:`bench.evaluation.reference.sample_chain_reference`: several chains from different
walks, burn-in, thinning; ``chain`` in the table, validated against rejection where both work
in tests/test_chain.py).
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import shlex
import subprocess
import sys
import tempfile
import time
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from bench.evaluation.reference import Statistics, sample_chain_reference, sample_reference, statistics
from mse.api import load
from mse.ir import model as ir
from mse.ir.evaluate import check_schedule
from mse.ir.schedule import Schedule
from mse.resources import bundled_names
from mse.solve.protocol import NoSolution, SolveRequest, get_solver

REPO = Path(__file__).resolve().parent.parent.parent
ONCE_TOLERANCE = 0.2
RATE_TOLERANCE = 0.1


def greta_sets(directory: Path) -> dict[str, ir.Model]:
    """Every Greta set, imported with ``mse import-greta`` into ``directory``."""
    shared = Path(os.environ.get("MSE_SHARED", REPO.parent / "shared")) / "greta"
    if not (shared / "lexicon.xml").exists():
        print(f"(Greta's data not found under {shared}: Greta sets skipped)")
        return {}
    subprocess.run([sys.executable, "-m", "mse", "import-greta", str(shared / "lexicon.xml"),
                    str(shared / "constraint.xml"), "-o", str(directory)], check=True, capture_output=True)
    return {f"greta:{path.stem}": load(str(path)) for path in sorted(directory.glob("*.xml"))}


def every_set(directory: Path) -> dict[str, ir.Model]:
    found = {name: load(name) for name in bundled_names()}
    found.update(greta_sets(directory))
    return found


def sampled(model: ir.Model, solver: str, duration: float, seeds: Sequence[int],
            budget: float | None = None, methods: Counter[str] | None = None,
            starts: int | None = None) -> tuple[list[Schedule], int]:
    """Timelines of ``solver`` for ``seeds`` (each re-checked), and how many found none; with
    ``budget``, the seeds in order until that many seconds have passed (at least one).  How
    each timeline was made (``Solution.method``; CP-SAT's own search: "cpsat") is counted in
    ``methods``.  With ``starts``, where the solver chains its timeline, only that many of its
    starts are solved (CP-SAT's at an hour: about 16 s of CPU each) and the other seeds chain
    one of them (two-stage sampling, counted as "... (start reused)")."""
    backend = get_solver(solver)
    schedules, failed = [], 0
    began = time.monotonic()
    reused: list[Schedule] = []  # with ``starts``: the starts solved so far (see below)
    reused_method = ""
    for seed in seeds:
        if budget is not None and seed != seeds[0] and time.monotonic() - began > budget:
            break
        made: list[tuple[Schedule, str]] = []
        if starts and reused_method:
            # Two-stage: the sampler's timeline for a seed is the chain run from its start for
            # that seed (its start: CP-SAT's timeline without the chain, `rejection=False`);
            # the first ``starts`` seeds are exactly that, later ones chain a kept start (in
            # turn) with their own seed.  The sampler's law is the chain's law averaged over
            # the starts' law, so this estimates it without bias (the starts are a sample of
            # ``starts`` of them), for a small part of the cost.
            from mse.solve.chain import chained

            if len(reused) < starts:
                try:
                    plain = backend.solve(model, SolveRequest(duration=duration, seed=seed, rejection=False))
                except NoSolution:
                    failed += 1
                    continue
                reused.append(plain.schedules[0])
                made.append((chained(model, reused[-1], seed, far=True), reused_method))
            else:
                made.append((chained(model, reused[seed % starts], seed, far=True), f"{reused_method} (start reused)"))
        else:
            try:
                result = backend.solve(model, SolveRequest(duration=duration, seed=seed))
            except NoSolution:
                failed += 1
                continue
            made = [(solution.schedule, solution.method or solver) for solution in result.solutions]
            if starts and made[0][1].endswith("+chain"):  # this seed's start, for the seeds after it
                plain = backend.solve(model, SolveRequest(duration=duration, seed=seed, rejection=False))
                reused.append(plain.schedules[0])
                reused_method = made[0][1]
        for schedule, method in made:
            if methods is not None:
                methods[method] += 1
            schedules.append(checked(model, schedule, solver, seed))
    return schedules, failed


def checked(model: ir.Model, schedule: Schedule, label: str, seed: int) -> Schedule:
    """``schedule``, re-checked by the one evaluator: an inconsistent timeline is an error, not
    a statistic."""
    problems = check_schedule(model, schedule)
    if problems:
        raise RuntimeError(f"{model.name} {label} seed {seed}: inconsistent timeline: {problems[0].message}")
    return schedule


@dataclass
class Row:
    name: str
    duration: float
    how: str  # "rejection" or "chain"
    acceptance: float
    reference: Statistics | None
    solvers: dict[str, Statistics]
    seconds: dict[str, float]
    methods: dict[str, Counter[str]] = field(default_factory=dict)

    def shares(self, solver: str) -> str:
        """How the solver's timelines were made, e.g. ``rejection 98%, walk 2%``."""
        made = self.methods.get(solver)
        total = sum(made.values()) if made else 0
        if not made or not total:
            return "-"
        return ", ".join(f"{how} {count / total:.0%}" for how, count in made.most_common())

    def errors(self, solver: str, model: ir.Model) -> tuple[float, float, str] | None:
        """|mean once-only signals - reference|, max |rate - reference| and its signal."""
        if self.reference is None:
            return None
        mine = self.solvers[solver]
        once = abs(mine.once_per_timeline - self.reference.once_per_timeline)
        worst, which = 0.0, "-"
        for signal in model.signals:
            wanted = self.reference.rate[signal.id]
            if math.isnan(wanted):
                continue
            error = abs(mine.rate[signal.id] - wanted)
            if error > worst:
                worst, which = error, signal.id
        return once, worst, which


def chain_reference_size(duration: float, wanted: int) -> dict[str, int]:
    """The chain reference's size: ``wanted`` timelines up to 60 s from 4 chains, 50 burn-in
    and 10 sweeps between kept ones; past 60 s a sweep holds as many windows as fit (0.1-0.3 s
    of CPU at an hour), so 10 timelines per chain (each chain from another walk: the once-only
    signals' rates need timelines far apart), 30 burn-in sweeps, 2 between."""
    if duration <= 60:
        return {"wanted": wanted, "burn": 50, "thin": 10}
    return {"wanted": wanted, "burn": 30, "thin": 2, "chains": max(4, wanted // 10)}


def measure(name: str, model: ir.Model, durations: Sequence[float], counts: dict[float, int], draws: int,
            wanted: int, seconds: float, minimum: int, solvers: Sequence[str],
            budget: float | None = None, chain_wanted: int = 400, starts: int | None = None) -> list[Row]:
    rows: list[Row] = []
    for duration in durations:
        began = time.monotonic()
        reference = sample_reference(model, duration, wanted=wanted, seed=1, max_draws=draws, max_seconds=seconds)
        how = "rejection"
        acceptance = reference.acceptance
        if len(reference.accepted) < minimum:
            reference = sample_chain_reference(model, duration, seed=1,
                                               **chain_reference_size(duration, chain_wanted))
            how = f"chain, {len(reference.accepted)}"
        took = {"reference": time.monotonic() - began}
        wanted_stats: Statistics | None = statistics(model, reference.accepted, duration)
        found: dict[str, Statistics] = {}
        methods: dict[str, Counter[str]] = {}
        for solver in solvers:
            began = time.monotonic()
            methods[solver] = Counter()
            schedules, failed = sampled(model, solver, duration, range(counts[duration]), budget, methods[solver],
                                        starts if duration > 60 and solver == "cpsat" else None)
            took[solver] = (time.monotonic() - began) / max(1, len(schedules) + failed)
            found[solver] = statistics(model, schedules, duration)
            if failed:
                print(f"   {name} {duration:g} s {solver}: {failed} seeds without a timeline")
        rows.append(Row(name, duration, how, acceptance, wanted_stats, found, took, methods))
    return rows


def _fmt(value: float | None) -> str:
    return "-" if value is None or value != value else f"{value:.2f}"


def summary_table(rows: Sequence[Row], models: dict[str, ir.Model], solvers: Sequence[str]) -> list[str]:
    head = ["set", "s", "reference (acceptance)", "timelines " + "/".join(solvers), "once-only / timeline: ref"]
    head += [f"{s}" for s in solvers]
    head += [f"max rate error {s}" for s in solvers]
    head += [f"made by ({s})" for s in solvers]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for row in rows:
        model = models[row.name]
        cells = [row.name, f"{row.duration:g}", f"{row.how} ({row.acceptance:.1%})",
                 "/".join(str(row.solvers[s].count) for s in solvers),
                 _fmt(row.reference.once_per_timeline if row.reference else None)]
        for solver in solvers:
            got = row.solvers[solver].once_per_timeline
            errors = row.errors(solver, model)
            mark = "" if errors is None or errors[0] <= ONCE_TOLERANCE else " ✗"
            cells.append(f"{got:.2f}{mark}")
        for solver in solvers:
            errors = row.errors(solver, model)
            if errors is None:
                cells.append("-")
            else:
                mark = "" if errors[1] <= RATE_TOLERANCE else " ✗"
                cells.append(f"{errors[1]:.2f} ({errors[2]}){mark}")
        cells += [row.shares(solver) for solver in solvers]
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def signal_table(rows: Sequence[Row], models: dict[str, ir.Model], solvers: Sequence[str]) -> list[str]:
    lines = []
    for row in rows:
        model = models[row.name]
        lines.append(f"**{row.name}, {row.duration:g} s** (reference: {row.how}, acceptance "
                     f"{row.acceptance:.1%}; timelines: " + ", ".join(
                         f"{s} {row.solvers[s].count}" for s in solvers) + ")")
        lines.append("")
        lines.append("| signal | reference | " + " | ".join(solvers) + " |")
        lines.append("|---|---|" + "---|" * len(solvers))
        for signal in model.signals:
            mark = " (per 10 s)" if signal.repetitive else ""
            wanted = row.reference.rate[signal.id] if row.reference else None
            lines.append(f"| {signal.id}{mark} | {_fmt(wanted)} | "
                         + " | ".join(_fmt(row.solvers[s].rate[signal.id]) for s in solvers) + " |")
        lines.append("")
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sets", nargs="*", default=None, help="these sets only (greta:NAME for Greta's)")
    parser.add_argument("--durations", nargs="*", type=float, default=[10.0, 60.0, 3600.0])
    parser.add_argument("--count", type=int, default=200, help="timelines per sampler at 10 s and 60 s")
    parser.add_argument("--long-count", type=int, default=40, help="timelines per sampler past 60 s")
    parser.add_argument("--solvers", nargs="*", default=["greedy", "cpsat"])
    parser.add_argument("--draws", type=int, default=200_000, help="prior draws at most per set and duration")
    parser.add_argument("--wanted", type=int, default=2000, help="consistent draws wanted")
    parser.add_argument("--seconds", type=float, default=60.0, help="wall time of rejection per set and duration")
    parser.add_argument("--min-accepted", type=int, default=200)
    parser.add_argument("--chain-wanted", type=int, default=400,
                        help="timelines of the chain reference (where rejection accepts too few)")
    parser.add_argument("--budget", type=float, default=None,
                        help="seconds per set, duration and sampler: fewer timelines past it (the table says how many)")
    parser.add_argument("--starts", type=int, default=None,
                        help="past 60 s, where CP-SAT's timeline starts the chain: solve only this many CP-SAT starts "
                             "and chain each other seed from one of them (two-stage sampling of the same law)")
    parser.add_argument("--markdown", type=Path, default=None, help="also write the tables to this file")
    parser.add_argument("--append", type=Path, default=None,
                        help="append the summary table to this file as a section (titled --title)")
    parser.add_argument("--title", default="Distribution", help="--append: the section's title")
    args = parser.parse_args(argv)
    counts = {d: (args.count if d <= 60 else args.long_count) for d in args.durations}
    with tempfile.TemporaryDirectory() as directory:
        models = every_set(Path(directory))
    if args.sets:
        models = {k: v for k, v in models.items() if k in args.sets}
    load = os.getloadavg()[0]
    header = (f"Reference: the prior (mse/ir/profile.py) conditioned on consistency, by rejection from at most "
              f"{args.draws} prior draws (or {args.seconds:g} s) until {args.wanted} are consistent, used when "
              f">= {args.min_accepted} are; otherwise `chain, N`: N timelines of the target's Markov chain "
              f"(mse/solve/chain.py; chains from different walks, burn-in and thinning as "
              f"bench.evaluation.distribution.chain_reference_size says; the acceptance column is then "
              f"rejection's).  Timelines per sampler: "
              + ", ".join(f"{counts[d]} at {d:g} s" for d in args.durations)
              + (f" (seeds 0..N-1, fewer past {args.budget:g} s per set, duration and sampler)" if args.budget
                 else " (seeds 0..N-1)")
              + (f"; past 60 s, where CP-SAT chains, {args.starts} CP-SAT starts solved and the other seeds "
                 "chained from one of them (two-stage)" if args.starts else "")
              + ".  Rate: once-only signals, fraction of timelines; repetitive, occurrences "
              f"per 10 s.  ✗: off target (once-only signals per timeline within {ONCE_TOLERANCE}, every rate "
              f"within {RATE_TOLERANCE}).  Load average {load:.1f}.")
    print(header, flush=True)
    rows: list[Row] = []
    for name, model in models.items():
        found = measure(name, model, args.durations, counts, args.draws, args.wanted, args.seconds,
                        args.min_accepted, args.solvers, args.budget, args.chain_wanted, args.starts)
        for line in summary_table(found, models, args.solvers)[2:]:
            print(line, flush=True)
        rows.extend(found)
    summary = summary_table(rows, models, args.solvers)
    details = signal_table(rows, models, args.solvers)
    print("\n".join(["", *summary]))
    if args.markdown is not None:
        text = ["# Recorded results: the samplers' distribution against the reference (issue 32)", "",
                "`python -m bench.evaluation.distribution` (bench/evaluation/distribution.py).", "", header, "",
                *summary, "", "## Per signal", "", *details]
        with contextlib.suppress(FileNotFoundError):
            args.markdown.unlink()
        args.markdown.write_text("\n".join(text) + "\n", encoding="utf-8")
    if args.append is not None:
        command = "python -m bench.evaluation.distribution " + shlex.join(argv if argv is not None else sys.argv[1:])
        section = ["", f"## {args.title}", "", f"`{command}`", "", header, "", *summary, ""]
        with args.append.open("a", encoding="utf-8") as out:
            out.write("\n".join(section))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

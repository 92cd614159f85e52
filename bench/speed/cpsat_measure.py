"""One measurement of bench/speed/cpsat.py, run in its own process against whichever ``mse``
is first on ``PYTHONPATH`` (this checkout, or the baseline of bench/baseline.py); prints one
JSON object.

    python -m bench.speed.cpsat_measure KIND '{"json": "arguments"}'

Kinds: ``bundled`` (sampling time per bundled set), ``scale`` (generated feasible sets),
``explain`` (generated infeasible sets), ``long`` (one long timeline: time, occurrences per
signal, peak memory), ``lint`` (deep lint of generated sets or of a folder), ``fidelity``
(per-signal occurrence rate and mean start of sampled timelines), ``prior`` (the same for
prior draws kept when consistent: rejection sampling of the target).  Uses only APIs that
exist before and after the CP-SAT rework (CpSatSolver.solve, explain, deep_lint).
"""

from __future__ import annotations

import json
import random
import resource
import sys
import time
from pathlib import Path
from typing import Any

from bench.generators.cpsat_sets import feasible_set, infeasible_set
from mse.api import load, loads
from mse.ir.schedule import to_ticks
from mse.resources import bundled_names
from mse.solve.protocol import NoSolution, SolveRequest, get_solver


def _peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def bundled(duration: float, runs: int) -> dict[str, Any]:
    solver = get_solver("cpsat")
    solver.solve(load("anger"), SolveRequest(duration=duration, seed=0))  # import and warm-up
    times: dict[str, list[float]] = {}
    cpu: dict[str, list[float]] = {}
    for name in bundled_names():
        model = load(name)
        times[name], cpu[name] = [], []
        for seed in range(runs):
            started, used = time.perf_counter(), time.process_time()
            solver.solve(model, SolveRequest(duration=duration, seed=seed))
            times[name].append(time.perf_counter() - started)
            cpu[name].append(time.process_time() - used)
    return {"times": times, "cpu": cpu}


def scale(signals: int, constraints: int, sets: int, duration: float, seeds: int = 1,
          locality: int | None = None, generator: str = "cpsat_sets") -> dict[str, Any]:
    """``generator``: ``cpsat_sets`` (bench/generators/cpsat_sets.py) or ``corpus`` (bench/generators/corpus.py's
    planted sets, the default sampler's bench generator: every operator, wide constraints)."""
    solver = get_solver("cpsat")
    solver.solve(load("anger"), SolveRequest(duration=10.0, seed=0))
    times, cpu, failures = [], [], 0
    for index in range(sets):
        if generator == "corpus":
            from corpus import planted_model

            model = planted_model(1000 + index, signals, constraints, duration)
        else:
            model = loads(feasible_set(signals, constraints, index, duration, locality=locality))
        for seed in range(seeds):
            started, used = time.perf_counter(), time.process_time()
            try:
                solver.solve(model, SolveRequest(duration=duration, seed=seed))
            except NoSolution:
                failures += 1
            times.append(time.perf_counter() - started)
            cpu.append(time.process_time() - used)
    return {"times": times, "cpu": cpu, "failures": failures}


def explain_sets(signals: int, constraints: int, sets: int, duration: float) -> dict[str, Any]:
    from mse.solve.cpsat.explain import explain

    solver = get_solver("cpsat")
    solver.solve(load("anger"), SolveRequest(duration=10.0, seed=0))
    rows = []
    for index in range(sets):
        model = loads(infeasible_set(signals, constraints, index, duration), path=f"infeasible{index}.xml")
        started = time.perf_counter()
        proven = False
        try:
            solver.solve(model, SolveRequest(duration=duration, seed=index))
        except NoSolution as error:
            proven = error.proven
        solve_time = time.perf_counter() - started
        started = time.perf_counter()
        explanation = explain(model, duration)
        rows.append({"sample_and_proof": solve_time, "explain": time.perf_counter() - started, "proven": proven,
                     "items": len(explanation.items) if explanation else 0,
                     "minimal": bool(explanation and explanation.minimal)})
    return {"rows": rows}


def long(name: str, duration: float, seed: int) -> dict[str, Any]:
    model = load(name)
    solver = get_solver("cpsat")
    request = SolveRequest(duration=duration, seed=seed, time_limit=4 * 3600)
    counts: dict[str, int] = {}
    starts: list[float] = []
    began, used = time.perf_counter(), time.process_time()
    if "stream" in solver.supports:
        import mse.solve.cpsat.solver as cpsat_solver

        marks: list[tuple[int, float]] = []  # (window begin, seconds) as each window is drawn
        drawing = cpsat_solver.frame_priors

        def marked(*args: Any, **kwargs: Any) -> Any:
            marks.append((args[2], time.perf_counter() - began))
            return drawing(*args, **kwargs)

        cpsat_solver.frame_priors = marked  # type: ignore[assignment]
        for occurrence in solver.stream(model, request):
            counts[occurrence.signal] = counts.get(occurrence.signal, 0) + 1
        total = time.perf_counter() - began
        quarter = to_ticks(duration) // 4
        first = min((t for b, t in marks if b >= quarter), default=total)
        last = total - min((t for b, t in marks if b >= 3 * quarter), default=total)
        starts = [first, last]
    else:
        [schedule] = solver.solve(model, request).schedules
        for occurrence in schedule.occurrences:
            counts[occurrence.signal] = counts.get(occurrence.signal, 0) + 1
    return {"seconds": time.perf_counter() - began, "cpu": time.process_time() - used, "counts": counts,
            "peak_mb": _peak_mb(), "quarters": starts}


def lint(constraints: int, locality: int | None, mandatory: float, folder: str | None,
         full: bool = False) -> dict[str, Any]:
    """Deep lint with its default budget, or with ``full`` every question asked (budget None)."""
    from mse.solve.cpsat.deep_lint import deep_lint

    options: dict[str, Any] = {"budget": None} if full else {}

    deep_lint(loads(feasible_set(6, 6, 0)), 10.0)  # imports
    if folder:
        paths = sorted(Path(folder).glob("*.xml")) if folder != "bundled" else [Path(n) for n in bundled_names()]
        models = [load(str(path)) for path in paths]
    else:
        models = [loads(feasible_set(constraints // 2, constraints, 0, locality=locality, mandatory=mandatory),
                        path=f"generated{constraints}.xml")]
    started, used = time.perf_counter(), time.process_time()
    codes: dict[str, int] = {}
    for model in models:
        for diagnostic in deep_lint(model, 10.0, **options):
            codes[diagnostic.code] = codes.get(diagnostic.code, 0) + 1
    return {"seconds": time.perf_counter() - started, "cpu": time.process_time() - used, "codes": codes}


def _tally(model: Any, schedules: list[Any], duration: int) -> dict[str, list[float]]:
    """Per signal: [occurrences per timeline, mean relative start of its occurrences]."""
    table = {}
    for signal in model.signals:
        found = [o for s in schedules for o in s.occurrences if o.signal == signal.id]
        mean_start = sum(o.start for o in found) / len(found) / duration if found else float("nan")
        table[signal.id] = [len(found) / max(1, len(schedules)), mean_start]
    return table


def fidelity(source: str, solver_name: str, runs: int, duration: float) -> dict[str, Any]:
    model = load(source)
    solver = get_solver(solver_name)
    schedules, failures = [], 0
    for seed in range(runs):
        try:
            schedules += solver.solve(model, SolveRequest(duration=duration, seed=seed)).schedules
        except NoSolution:
            failures += 1
    return {"table": _tally(model, schedules, to_ticks(duration)), "failures": failures, "runs": runs}


def prior(source: str, draws: int, duration: float) -> dict[str, Any]:
    """Rejection sampling of the target: prior draws (mse.solve.cpsat.prior, exact) kept when
    consistent."""
    from mse.ir.evaluate import check_schedule
    from mse.ir.schedule import Occurrence, Schedule
    from mse.solve.cpsat.prior import frame_priors

    model = load(source)
    ticks = to_ticks(duration)
    kept = []
    for seed in range(draws):
        priors = frame_priors(model, ticks, 0, ticks, {}, {}, random.Random(seed))
        schedule = Schedule.of(ticks, [Occurrence(p.start, p.start + p.length, p.signal)
                                       for slots in priors.values() for p in slots if p.present])
        if not check_schedule(model, schedule):
            kept.append(schedule)
    return {"table": _tally(model, kept, ticks), "accepted": len(kept), "draws": draws}


def long_prior(name: str, duration: float, draws: int = 5) -> dict[str, Any]:
    """Occurrences per signal of the prior (no constraints) over ``duration``, mean of draws."""
    from mse.solve.cpsat.prior import frame_priors

    model = load(name)
    ticks = to_ticks(duration)
    counts: dict[str, float] = {}
    for seed in range(draws):
        for slots in frame_priors(model, ticks, 0, ticks, {}, {}, random.Random(seed)).values():
            for p in slots:
                if p.present:
                    counts[p.signal] = counts.get(p.signal, 0.0) + 1.0 / draws
    return {"counts": counts}


def controls(source: str, solver_name: str, runs: int, duration: float) -> dict[str, Any]:
    """The control condition and never-occurring signals: of ``runs`` constraint-less
    timelines, how many violate a constraint; then, with every signal's probabilities set to 0
    in turn (one at a time, a set per signal), how many default timelines still show it."""
    import dataclasses

    from mse.ir.evaluate import check_schedule

    model = load(source)
    solver = get_solver(solver_name)
    violating = failures = 0
    for seed in range(runs):
        try:
            request = SolveRequest(duration=duration, seed=seed, mode="constraint-less")
            [schedule] = solver.solve(model, request).schedules
        except NoSolution:
            failures += 1
            continue
        violating += any(v.kind == "constraint" for v in check_schedule(model, schedule))
    shown = timelines = zero_failures = 0
    for signal in model.signals:
        muted = dataclasses.replace(signal, probability_start=0.0, probability_end=0.0)
        variant = dataclasses.replace(model, signals=tuple(muted if s.id == signal.id else s for s in model.signals))
        for seed in range(max(1, runs // 10)):
            try:
                [schedule] = solver.solve(variant, SolveRequest(duration=duration, seed=seed)).schedules
            except NoSolution:
                zero_failures += 1
                continue
            timelines += 1
            shown += any(o.signal == signal.id for o in schedule.occurrences)
    return {"constraints": len(model.constraints), "violating": violating, "runs": runs, "failures": failures,
            "zero_shown": shown, "zero_timelines": timelines, "zero_failures": zero_failures}


KINDS = {"controls": controls, "bundled": bundled, "long_prior": long_prior, "scale": scale, "explain": explain_sets,
         "long": long,
         "lint": lint, "fidelity": fidelity, "prior": prior}

if __name__ == "__main__":
    result = KINDS[sys.argv[1]](**json.loads(sys.argv[2]))
    result["peak_mb"] = result.get("peak_mb", _peak_mb())
    print(json.dumps(result))

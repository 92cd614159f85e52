"""Run sampling jobs in a subprocess against a given version of ``mse`` (this checkout, or the
baseline of :mod:`bench.baseline`), so that the bench compares two versions of the sampler in
the same run, under the same load (``python -m bench.speed.sample --baseline REF``).

A job is a list of items ``{"name", "model" (canonical IR JSON), "duration", "seeds",
"solver", "warm"}``; the subprocess answers, per item, the CPU and wall time of sampling every
seed (one request per seed, as ``mse sample --seed S`` would), how many timelines it returned
and, when the solver counts them, its walks and backtracks (read from the result where the version
returns one, ``mse.solve.protocol.SolveResult``, else from the solver's attributes).  An item may carry a ``budget`` in
seconds: once it is spent, its remaining seeds are skipped (and counted as such).  The script run in the
subprocess uses only what both versions have: ``mse.ir.canonical.model_from_json``,
``mse.solve.protocol.get_solver`` and ``SolveRequest``.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from bench.baseline import run_python

#: Executed as ``python -c SCRIPT`` with the job on stdin.
SCRIPT = r"""
import json, sys, time
from mse.ir.canonical import model_from_json
from mse.solve.protocol import NoSolution, SolveRequest, get_solver
job = json.load(sys.stdin)
results = []
for item in job:
    model = model_from_json(item["model"], path=item["name"])
    solver = get_solver(item["solver"])
    for seed in range(item.get("warm", 0)):  # the per-model plan is built once, as in a long run
        try:
            solver.solve(model, SolveRequest(duration=item["duration"], seed=10**6 + seed))
        except NoSolution:
            pass
    ok = attempts = restarts = 0
    times = []
    cpu_times = []
    methods = []  # per seed: how the solver made it ("walk", "cpsat"), or "" when it failed
    cpu, wall = time.process_time(), time.perf_counter()
    skipped = 0
    for seed in item["seeds"]:
        if time.perf_counter() - wall > item.get("budget", float("inf")):
            skipped += 1  # this item already took its time budget: the rest is not run
            continue
        began, began_cpu = time.perf_counter(), time.process_time()
        try:
            result = solver.solve(model, SolveRequest(duration=item["duration"], seed=seed))
            ok += 1
            report = result if hasattr(result, "solutions") else solver
            methods.extend([m or "?" for m in getattr(report, "methods", None) or ["?"]])
            attempts += getattr(report, "attempts", 0)
            restarts += getattr(report, "restarts", 0)
        except NoSolution:
            methods.append("")
        times.append(time.perf_counter() - began)
        cpu_times.append(time.process_time() - began_cpu)
    results.append({"name": item["name"], "cpu": time.process_time() - cpu, "wall": time.perf_counter() - wall,
                    "ok": ok, "attempts": attempts, "restarts": restarts, "times": times, "cpu_times": cpu_times,
                    "skipped": skipped,
                    "methods": methods})
print(json.dumps(results))
"""


def run_job(root: Path | None, job: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Run ``job`` with the sampler of ``root`` (None: this checkout) in a fresh interpreter."""
    done = run_python(root, ["-c", SCRIPT], stdin=json.dumps(list(job)))
    if done.returncode != 0:
        raise RuntimeError(f"bench subprocess failed ({root or 'this checkout'}):\n{done.stderr[-2000:]}")
    result: list[dict[str, Any]] = json.loads(done.stdout.strip().splitlines()[-1])
    return result

"""Run sampling jobs in a subprocess against a given source tree (this one, or another git
revision extracted with ``git archive``), so that the bench compares two versions of the
sampler in the same run, under the same load (``bench/sample.py --baseline-ref REV``).

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
import subprocess
import sys
import tarfile
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent

#: Executed as ``python -c SCRIPT ROOT`` with the job on stdin.
SCRIPT = r"""
import json, sys, time
sys.path.insert(0, sys.argv[1])
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


def extract(revision: str, into: Path) -> Path:
    """The source tree of ``revision`` (``git archive``: no worktree, no change to the
    repository) under ``into``; returns its root."""
    archive = subprocess.run(
        ["git", "archive", "--format=tar", revision], cwd=REPO, capture_output=True, check=True
    ).stdout
    root = into / revision.replace("/", "_")
    root.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryFile() as handle:
        handle.write(archive)
        handle.seek(0)
        with tarfile.open(fileobj=handle) as tar:
            tar.extractall(root, filter="data")
    return root


def run_job(root: Path, job: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Run ``job`` with the sampler of the tree at ``root`` in a fresh interpreter."""
    done = subprocess.run(
        [sys.executable, "-c", SCRIPT, str(root)], input=json.dumps(list(job)), capture_output=True, text=True,
        check=False,
    )
    if done.returncode != 0:
        raise RuntimeError(f"bench subprocess failed ({root}):\n{done.stderr[-2000:]}")
    result: list[dict[str, Any]] = json.loads(done.stdout.strip().splitlines()[-1])
    return result

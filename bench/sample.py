"""Benchmark of the greedy sampler (issue 3).  Prints numbers; asserts nothing.

    python bench/sample.py                 # every bundled emotion at 4, 10 and 30 s
    python bench/sample.py --count 2000 --emotions embarrassment --durations 10

Reports, per bundled emotion and duration: timelines per second in one process for one
``--count`` request (wall clock, and per second of CPU time of this process, which other
processes on the machine disturb less; every timeline is verified by ``check_schedule``, as
the sampler always does), mean signals per timeline, restart rate (restarted attempts /
attempts), with the load average before and after; then the wall time of
``mse sample --duration 10`` against a bare ``python -c pass``, both with byte-code caching on
as for an installed user (PYTHONDONTWRITEBYTECODE, set in this environment, is removed for
those subprocesses; one warm-up run writes the cache), and for comparison without it.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from mse.api import load  # noqa: E402
from mse.resources import bundled_names  # noqa: E402
from mse.solve.greedy import GreedySolver  # noqa: E402
from mse.solve.protocol import NoSolution, SolveRequest  # noqa: E402


def bench_emotion(name: str, duration: float, count: int, seed: int) -> tuple[float, float, float, float, int]:
    """(timelines/s wall, timelines/s CPU, mean signals, restart rate, failures) for ``count``
    timelines of one request (``--count``), as ``mse sample --count N`` does."""
    model = load(name)
    solver = GreedySolver()
    solver.solve(model, SolveRequest(duration=duration, seed=seed, count=5))  # warm the per-model cache
    wall, cpu = time.perf_counter(), time.process_time()
    try:
        schedules = solver.solve(model, SolveRequest(duration=duration, seed=seed, count=count))
        attempts, restarts, failures = solver.attempts, solver.restarts, 0
    except NoSolution:  # rare: redo one request per timeline so that a failure costs one only
        schedules, attempts, restarts, failures = [], 0, 0, 0
        wall, cpu = time.perf_counter(), time.process_time()
        for index in range(count):
            try:
                schedules += solver.solve(model, SolveRequest(duration=duration, seed=seed + index))
            except NoSolution:
                failures += 1
            attempts += solver.attempts
            restarts += solver.restarts
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    signals = sum(len(s.occurrences) for s in schedules) / max(1, len(schedules))
    return count / wall, count / cpu, signals, restarts / max(1, attempts), failures


def wall_times(commands: list[list[str]], repeat: int, env: dict[str, str]) -> list[float]:
    """Median wall time in seconds of each command over ``repeat`` runs.  Each is run once
    first (not counted: it writes the byte-code cache), then the commands alternate, so a
    change of load on the machine affects them alike."""
    def run(command: list[str]) -> float:
        started = time.perf_counter()
        subprocess.run(command, cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False, env=env)
        return time.perf_counter() - started

    for command in commands:
        run(command)
    times: list[list[float]] = [[] for _ in commands]
    for _ in range(repeat):
        for index, command in enumerate(commands):
            times[index].append(run(command))
    return [statistics.median(found) for found in times]


def installed_env(cache: str) -> dict[str, str]:
    """The environment of an installed user: byte-code caching on.  This environment sets
    PYTHONDONTWRITEBYTECODE=1, with which every start recompiles every module of ``mse`` (an
    installed wheel has its .pyc files), so it is removed for the measured subprocesses; the
    cache goes to ``cache`` (PYTHONPYCACHEPREFIX), not into the shared checkout."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONPYCACHEPREFIX"] = cache
    return env


def bench_cli(repeat: int) -> None:
    executable = shutil.which("mse", path=str(Path(sys.executable).parent)) or ""
    cli = [executable] if executable else [sys.executable, "-m", "mse"]
    command = [*cli, "sample", "--duration", "10", "--seed", "1", "--format", "json"]
    bare_command = [sys.executable, "-c", "pass"]
    with tempfile.TemporaryDirectory() as cache:
        bare, sample = wall_times([bare_command, command], repeat, installed_env(cache))
    unset = " (PYTHONDONTWRITEBYTECODE unset for these runs)" if os.environ.get("PYTHONDONTWRITEBYTECODE") else ""
    print(f"CLI start, byte-code cached as when installed, one warm-up run not counted{unset}:")
    print(f"python -c pass:             {bare * 1000:7.1f} ms (median of {repeat})")
    print(f"mse sample --duration 10:   {sample * 1000:7.1f} ms (median of {repeat})")
    print(f"ratio:                      {sample / bare:7.2f}x (target <= 10x)")
    if os.environ.get("PYTHONDONTWRITEBYTECODE"):
        bare, sample = wall_times([bare_command, command], repeat, dict(os.environ))
        print("for comparison, this environment as is (PYTHONDONTWRITEBYTECODE=1: no byte-code cache):")
        print(f"python -c pass:             {bare * 1000:7.1f} ms")
        print(f"mse sample --duration 10:   {sample * 1000:7.1f} ms")
        print(f"ratio:                      {sample / bare:7.2f}x")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--count", type=int, default=1000, help="timelines per emotion and duration")
    parser.add_argument("--emotions", nargs="*", default=None, help="bundled names (default: all)")
    parser.add_argument("--durations", nargs="*", type=float, default=[4.0, 10.0, 30.0])
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--repeat", type=int, default=7, help="runs of each command for the CLI timing")
    parser.add_argument("--no-cli", action="store_true", help="skip the CLI start-up timing")
    args = parser.parse_args()

    emotions = args.emotions or bundled_names()
    print(f"load average before: {os.getloadavg()[0]:.2f} (other processes slow the wall-clock rate)")
    print(f"{'emotion':15s} {'dur s':>5s} {'timelines/s':>12s} {'(CPU time)':>11s} {'signals':>8s} "
          f"{'restarts':>9s} {'failed':>6s}")
    total_attempt_rates = []
    for name in emotions:
        for duration in args.durations:
            rate, cpu_rate, signals, restart_rate, failures = bench_emotion(name, duration, args.count, args.seed)
            total_attempt_rates.append(restart_rate)
            print(f"{name:15s} {duration:5g} {rate:12.0f} {cpu_rate:11.0f} {signals:8.2f} {restart_rate:9.2%} "
                  f"{failures:6d}")
    if total_attempt_rates:
        print(f"mean restart rate over all rows: {statistics.mean(total_attempt_rates):.2%}")

    print(f"load average after: {os.getloadavg()[0]:.2f}")
    if not args.no_cli:
        bench_cli(args.repeat)


if __name__ == "__main__":
    main()

"""A long fuzz run of mse's readers (issue 13): the targets of ``tests/fuzzing.py``, run for
minutes instead of the CI suite's seconds.

    python -m bench.robustness.fuzz --seconds 600       # atheris if installed, else hypothesis
    python -m bench.robustness.fuzz --engine hypothesis --seconds 60 --targets xml,expression

Engines: ``atheris`` (coverage-guided libFuzzer over mse's own code, seeded with the bundled
sets, the fixtures, a timeline, a BVH clip and compiled IR; ``pip install atheris``) or
``hypothesis`` (the structure-aware generators of the CI suite, many more examples).
Each case runs under a wall-clock bound (``--case-seconds``); the fuzzing process runs under
an address-space limit (``--rss-mb``), so a blow-up shows as a failure instead of a swap storm.

Prints, per target and in total: cases, tracebacks (any exception but a located MseError,
and every broken invariant), timeouts, the worst time of one case (also as a ratio to
compiling the bundled embarrassment set, measured in the same run) and the peak RSS.
Failing inputs are saved under ``--failures`` (default: a temporary folder).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
import traceback
from pathlib import Path
from typing import Any

from bench.baseline import NEUTRAL, environment

TARGET_NAMES = ("xml", "expression", "timeline", "bvh", "ir", "learn", "render", "stdio", "model")


# -- one case ---------------------------------------------------------------------------------------
class Stats:
    """Counts per target, written to a JSON file so that the parent can report them even when
    libFuzzer ends the worker process."""

    def __init__(self, path: Path, failures: Path) -> None:
        self.path = path
        self.failures = failures
        self.data: dict[str, Any] = {
            "targets": {name: {"cases": 0, "tracebacks": 0, "timeouts": 0, "worst_s": 0.0} for name in TARGET_NAMES},
            "peak_rss_kib": 0,
            "examples": [],
        }
        self.since_flush = 0

    def record(self, name: str, seconds: float, peak_kib: int, problem: str | None, case: bytes) -> None:
        entry = self.data["targets"][name]
        entry["cases"] += 1
        entry["worst_s"] = max(entry["worst_s"], seconds)
        self.data["peak_rss_kib"] = max(self.data["peak_rss_kib"], peak_kib)
        if problem is not None:
            key = "timeouts" if problem.startswith("timeout") else "tracebacks"
            entry[key] += 1
            saved = self.failures / f"{name}-{entry['cases']}.bin"
            saved.write_bytes(case)
            if len(self.data["examples"]) < 20:
                self.data["examples"].append({"target": name, "input": str(saved), "problem": problem[-2000:]})
            self.flush()
        self.since_flush += 1
        if self.since_flush >= 200:
            self.flush()

    def flush(self) -> None:
        self.since_flush = 0
        self.path.write_text(json.dumps(self.data))


def run_case(name: str, case: Any, stats: Stats, case_seconds: float, seed: int = 0) -> None:
    from tests import fuzzing

    raw = case if isinstance(case, bytes) else str(case).encode("utf-8", errors="surrogatepass")
    problem: str | None = None
    measure = fuzzing.Measure()
    try:
        with fuzzing.bounded(case_seconds) as measure:
            fuzzing.TARGETS[name](case, seed)
    except fuzzing.CaseTimeout as timeout:
        problem = f"timeout: {timeout}"
    except Exception:  # a traceback or a broken invariant: record it and keep fuzzing
        problem = traceback.format_exc()
    stats.record(name, measure.seconds, measure.peak_rss_kib, problem, raw)


# -- engines ----------------------------------------------------------------------------------------
def hypothesis_worker(args: argparse.Namespace, stats: Stats) -> None:
    names = args.targets
    deadline = time.monotonic() + args.seconds
    share = args.seconds / len(names)
    for name in names:
        stop = min(deadline, time.monotonic() + share)
        batch = _batch(name, stats, args.case_seconds)
        while time.monotonic() < stop:
            batch()
    stats.flush()


def _batch(name: str, stats: Stats, case_seconds: float) -> Any:
    """200 fresh examples of one target per call."""
    from hypothesis import HealthCheck, given, settings
    from hypothesis import strategies as st

    from tests import fuzzing

    @settings(max_examples=200, deadline=None, database=None, suppress_health_check=list(HealthCheck))
    @given(case=fuzzing.STRATEGIES[name], seed=st.integers(0, 2**31 - 1))
    def batch(case: Any, seed: int) -> None:
        run_case(name, case, stats, case_seconds, seed)

    return batch


def _seed_corpus(folder: Path) -> None:
    from tests import fuzzing

    seeds: list[tuple[int, bytes]] = [(0, doc) for doc in fuzzing.seed_documents()]
    seeds += [
        (1, text.encode())
        for text in (
            "exists(a) and includes(a, b)",
            "start(b) &gt; stop(a) + 0.5 implies not exists(c)",
            "equal(start(a), stop(b), 0.2) or precedes(a, c)",
        )
    ]
    seeds += [(2, text.encode()) for text in fuzzing.seed_timelines()]
    seeds.append((3, fuzzing.SEED_BVH.encode()))
    seeds += [(4, text.encode()) for text in fuzzing.seed_ir()]
    seeds += [(5, bytes([0]) + fuzzing.SEED_TABLE.encode()), (5, bytes([2]) + fuzzing.SEED_EAF.encode())]
    seeds += [(6, text.encode()) for text in fuzzing.seed_timelines()]
    seeds += [(7, bytes([command, 0])) for command in range(len(fuzzing.STDIO_COMMANDS))]
    for number, (target, data) in enumerate(seeds):
        (folder / f"seed-{number}").write_bytes(bytes([target]) + data)


def atheris_worker(args: argparse.Namespace, stats: Stats) -> None:
    import atheris

    with atheris.instrument_imports(include=["mse"]):
        from tests import fuzzing  # noqa: F401  (imports and instruments mse)

    names = args.targets

    def one_input(data: bytes) -> None:
        if not data:
            return
        name = TARGET_NAMES[data[0] % len(TARGET_NAMES)]
        if name not in names:
            return
        payload = data[1:]
        binary = name in ("xml", "bvh", "ir", "learn", "stdio", "model")
        case: Any = payload if binary else payload.decode("utf-8", errors="replace")
        run_case(name, case, stats, args.case_seconds)

    corpus = Path(tempfile.mkdtemp(prefix="mse-fuzz-corpus-"))
    _seed_corpus(corpus)
    libfuzzer = [
        sys.argv[0],
        str(corpus),
        f"-max_total_time={int(args.seconds)}",
        "-timeout=0",  # our own alarm bounds each case (libFuzzer's would share SIGALRM)
        f"-rss_limit_mb={args.rss_mb}",
        "-max_len=200000",
        "-print_final_stats=1",
    ]
    atheris.Setup(libfuzzer, one_input)
    atheris.Fuzz()


# -- the parent: start the worker, report ---------------------------------------------------------------
def baseline_seconds() -> float:
    from mse.api import compile_source
    from mse.resources import behaviour_sets_dir

    data = (behaviour_sets_dir() / "embarrassment.xml").read_bytes()
    compile_source("warm.xml", data)
    times = []
    for _ in range(7):
        began = time.perf_counter()
        compile_source("x.xml", data)
        times.append(time.perf_counter() - began)
    return statistics.median(times)


def report(stats: dict[str, Any], baseline: float, seconds: float, engine: str) -> int:
    totals = {"cases": 0, "tracebacks": 0, "timeouts": 0}
    worst = 0.0
    print(f"engine {engine}, {seconds:.0f} s; baseline (compile embarrassment.xml) {baseline * 1000:.1f} ms")
    print(f"{'target':<12}{'cases':>9}{'tracebacks':>12}{'timeouts':>10}{'worst case':>13}{'x baseline':>12}")
    for name, entry in stats["targets"].items():
        if not entry["cases"]:
            continue
        for key in totals:
            totals[key] += entry[key]
        worst = max(worst, entry["worst_s"])
        print(
            f"{name:<12}{entry['cases']:>9}{entry['tracebacks']:>12}{entry['timeouts']:>10}"
            f"{entry['worst_s']:>11.2f} s{entry['worst_s'] / baseline:>11.0f}x"
        )
    print(
        f"{'total':<12}{totals['cases']:>9}{totals['tracebacks']:>12}{totals['timeouts']:>10}"
        f"{worst:>11.2f} s{worst / baseline:>11.0f}x"
    )
    print(f"peak RSS of the fuzzing process: {stats['peak_rss_kib'] / 1024:.0f} MB")
    for example in stats["examples"][:5]:
        tail = "\n".join(example["problem"].rstrip().splitlines()[-8:])
        print(f"\n--- {example['target']}: {example['input']}\n{tail}")
    return 1 if totals["tracebacks"] or totals["timeouts"] else 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seconds", type=float, default=300.0, help="total fuzzing time (default 300)")
    parser.add_argument("--engine", choices=("auto", "atheris", "hypothesis"), default="auto")
    parser.add_argument("--targets", default=",".join(TARGET_NAMES), help="comma-separated targets")
    parser.add_argument("--case-seconds", type=float, default=20.0, help="wall-clock bound of one case")
    parser.add_argument("--rss-mb", type=int, default=4096, help="memory bound of the fuzzing process")
    parser.add_argument("--failures", type=Path, help="folder for failing inputs")
    parser.add_argument("--worker", type=Path, help=argparse.SUPPRESS)
    args, _ = parser.parse_known_args()
    args.targets = [t for t in args.targets.split(",") if t]
    if args.engine == "auto":
        try:
            import atheris  # noqa: F401

            args.engine = "atheris"
        except ImportError:
            args.engine = "hypothesis"
    if args.worker is not None:  # the fuzzing process itself
        limit = args.rss_mb * 1024 * 1024
        resource.setrlimit(resource.RLIMIT_AS, (limit * 4, limit * 4))  # address space, not RSS
        failures = args.failures or Path(tempfile.mkdtemp(prefix="mse-fuzz-failures-"))
        failures.mkdir(parents=True, exist_ok=True)
        stats = Stats(args.worker, failures)
        stats.flush()
        (atheris_worker if args.engine == "atheris" else hypothesis_worker)(args, stats)
        return 0
    stats_file = Path(tempfile.mkdtemp(prefix="mse-fuzz-")) / "stats.json"
    command = [sys.executable, "-m", "bench.robustness.fuzz", "--worker", str(stats_file), "--engine", args.engine]
    command += ["--seconds", str(args.seconds), "--targets", ",".join(args.targets)]
    command += ["--case-seconds", str(args.case_seconds), "--rss-mb", str(args.rss_mb)]
    if args.failures:
        command += ["--failures", str(args.failures)]
    began = time.monotonic()
    env = environment(None, MSE_CACHE_DIR=os.environ.get("MSE_CACHE_DIR", str(stats_file.parent / "cache")))
    worker = subprocess.run(
        command, env=env, cwd=NEUTRAL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, check=False
    )
    elapsed = time.monotonic() - began
    if not stats_file.exists():
        print(worker.stderr.decode(errors="replace")[-4000:], file=sys.stderr)
        return 2
    stats = json.loads(stats_file.read_text())
    if worker.returncode not in (0,):  # libFuzzer found a crash it handles itself (e.g. RSS limit)
        print(f"worker exited {worker.returncode}:\n{worker.stderr.decode(errors='replace')[-3000:]}")
    code = report(stats, baseline_seconds(), elapsed, args.engine)
    return code or (1 if worker.returncode else 0)


if __name__ == "__main__":
    raise SystemExit(main())

"""Speed of ``mse animate`` on a 10 s timeline: first run (empty caches) and warm runs.

    python -m bench.speed.animate_speed [--shared ../shared] [--runs 3]

Timelines: the bundled ``embarrassment`` set sampled for 10 s (seed 1: a bow and a hand on the
mouth that overlap), animated with the starter library, Bandai dataset 1 and dataset 2
(whose actions it lacks: starter fallbacks), and a 10 s timeline of dataset 2's own actions
(wave both hands, raise both hands, walk; declared by a small set written for the bench).
Each case runs ``mse animate`` as a user would, in a fresh process: once with an empty
``MSE_CACHE_DIR`` (first run: models are trained), then ``--runs`` times warm (median
reported). The baseline, measured in the same run, is ``mse sample`` of the same 10 s
(process start and compile): the ratio says how many samples one animation costs.
Target: warm <= 2 s with dataset 1 and dataset 2.
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

ROOT = Path(__file__).resolve().parent.parent.parent
MSE = [sys.executable, "-m", "mse"]

DS2_SET = """<?xml version="1.0" encoding="UTF-8"?>
<expression name="greeting">
  <modality name="gesture" exclusive="false"/>
  <signals>
    <signal id="wave" modality="gesture" lexeme="gesture=wave" min_duration="2" max_duration="4">
      <motion action="wave_both_hands"/>
    </signal>
    <signal id="raise" modality="gesture" lexeme="gesture=raise" min_duration="1" max_duration="3">
      <motion action="raise_up_both_hands"/>
    </signal>
    <signal id="walk" modality="torso" lexeme="torso=walk" min_duration="3" max_duration="5">
      <motion action="walk"/>
    </signal>
  </signals>
  <constraints/>
</expression>
"""


def _run(argv: list[str], env: dict[str, str]) -> float:
    started = time.perf_counter()
    done = subprocess.run(argv, capture_output=True, text=True, env=env, cwd=ROOT)
    took = time.perf_counter() - started
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(argv)} failed:\n{done.stderr}")
    return took


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--shared", default=os.environ.get("MSE_SHARED", str(ROOT.parent / "shared")))
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args()
    shared = Path(args.shared)
    work = Path(tempfile.mkdtemp(prefix="mse-animate-speed-"))
    env = dict(os.environ)
    timeline = work / "embarrassment.json"
    with timeline.open("w") as handle:
        subprocess.run(
            [*MSE, "sample", "embarrassment", "--duration", "10", "--seed", "1", "--format", "json"],
            stdout=handle,
            check=True,
            cwd=ROOT,
        )
    greeting = work / "greeting.xml"
    greeting.write_text(DS2_SET)
    ds2_timeline = work / "greeting.json"
    from mse.timeline import Timeline, TimelineSignal

    signals = (
        TimelineSignal("wave", "gesture", "gesture=wave", 0.5, 4.0),
        TimelineSignal("raise", "gesture", "gesture=raise", 3.5, 5.5),
        TimelineSignal("walk", "torso", "torso=walk", 6.0, 10.0),
    )
    ds2_timeline.write_text(Timeline("greeting", 10.0, signals).dumps() + "\n")
    baseline = statistics.median(
        _run([*MSE, "sample", "embarrassment", "--duration", "10", "--seed", "1", "--format", "json"], env)
        for _ in range(args.runs)
    )
    print(f"baseline: mse sample of 10 s, {baseline:.2f} s")
    ds1, ds2 = str(shared / "motion" / "bandai-ds1"), str(shared / "motion" / "bandai-ds2")
    cases = [
        ("embarrassment, starter", timeline, []),
        ("embarrassment, bandai-ds1", timeline, ["--library", ds1]),
        ("embarrassment, bandai-ds2", timeline, ["--library", ds2]),
        ("ds2 actions, bandai-ds2", ds2_timeline, ["--library", ds2, "--expression", str(greeting)]),
    ]
    print(f"{'case':<30} {'first run':>10} {'warm':>8} {'warm/baseline':>14}  target warm <= 2 s")
    for name, source, extra in cases:
        cache = work / f"cache-{len(name)}-{abs(hash(name)) % 10_000}"
        case_env = dict(env, MSE_CACHE_DIR=str(cache))
        out = work / "out"
        argv = [*MSE, "animate", str(source), "-o", str(out), *extra]

        def once(argv: list[str] = argv, case_env: dict[str, str] = case_env, out: Path = out) -> float:
            # `mse animate` refuses a folder that holds another run's files (E105)
            shutil.rmtree(out, ignore_errors=True)
            return _run(argv, case_env)

        first = once()
        warm = statistics.median(once() for _ in range(args.runs))
        verdict = "met" if warm <= 2.0 else "NOT met"
        print(f"{name:<30} {first:9.2f}s {warm:7.2f}s {warm / baseline:13.1f}x  {verdict}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

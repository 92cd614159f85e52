"""Benchmark of `mse live` (issue 28): scripted one-hour dialogues.  Prints numbers; asserts nothing.

    python -m bench.speed.dialogue                      # one 1-hour dialogue, seed 1
    python -m bench.speed.dialogue --dialogues 3 --minutes 60 --seed 5

Each dialogue changes emotion every 2-20 s (uniform), drawing from every bundled set and every
set `mse import-greta` makes of $MSE_SHARED/greta (default ../shared); about half the episodes
are announced (``until`` = the next change), a sixth are announced but interrupted before their
announced end, the rest unannounced; utterances with word timings (0.15-0.5 s words, one stressed)
fill part of each episode.  Measured:

- speed: `mse live SCRIPT -o out.json` (a subprocess, start-up included) and the planning alone in
  process, as multiples of real time (target >= 100x);
- memory: RSS of the process when the dialogue's clock passes minute 5 and at its end (target:
  growth <= 10 MB); every set is loaded before minute 5 so that loading is not counted as growth;
- consistency: every episode under `mse check` (the evaluator), and every announced episode that
  ran as planned under an independent checker (tests/independent_checker.py: docs/semantics.md written
  out as plain loops, without mse.ir.evaluate);
- rates: occurrences per minute of each set's announced episodes, pooled over the dialogues and
  over ``--rate-seeds`` plans of each script (one hour gives each of the 19 sets about a dozen
  announced episodes, whose count alone varies by ~10 %), against the same set sampled alone at
  the same lengths as many times, target within 10 %;
- latency: from an emotion event to the first committed occurrence of its episode
  (``Session.stream``), p50 / p99 over every event, wall-clock and CPU time of the thread (the
  machine is shared: the CPU time is the work; target p99 <= 10 ms).
"""

from __future__ import annotations

import argparse
import json
import os
import random
import statistics
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

from mse.api import load
from mse.dialogue import Session, plan_script, read_script
from mse.dialogue.check import check_dialogue
from mse.resources import behaviour_sets_dir, bundled_names
from tests.independent_checker import problems as naive_problems

REPO = Path(__file__).resolve().parents[2]
SHARED = Path(os.environ.get("MSE_SHARED", REPO.parent / "shared"))
WORDS = ("well", "I", "really", "do", "not", "know", "what", "you", "expected", "me", "to", "say", "about",
         "all", "of", "that", "now")


def rss_mb() -> float:
    with open("/proc/self/statm") as handle:
        return int(handle.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def import_greta(folder: Path) -> list[Path]:
    greta = SHARED / "greta"
    if not (greta / "lexicon.xml").is_file():
        print(f"note: no Greta data in {greta}: bundled sets only", file=sys.stderr)
        return []
    subprocess.run([sys.executable, "-m", "mse", "import-greta", str(greta / "lexicon.xml"),
                    str(greta / "constraint.xml"), "-o", str(folder)], check=True, capture_output=True,
                   env={**os.environ, "PYTHONPATH": str(REPO)})
    return sorted(folder.glob("*.xml"))


def make_script(pool: list[str], minutes: float, rng: random.Random) -> list[dict[str, Any]]:
    """One scripted dialogue (see the module docstring)."""
    events: list[dict[str, Any]] = []
    end = minutes * 60.0
    t = 0.0
    while t < end - 2.0:
        length = min(rng.uniform(2.0, 20.0), end - t)
        nxt = round(t + length, 3)
        event: dict[str, Any] = {"t": round(t, 3), "emotion": rng.choice(pool),
                                 "intensity": round(rng.uniform(0.3, 1.0), 2)}
        kind = rng.random()
        if kind < 0.5:
            event["until"] = nxt
        elif kind < 0.67:
            event["until"] = round(nxt + rng.uniform(0.5, 5.0), 3)  # announced, then interrupted
        events.append(event)
        at = t + rng.uniform(0.1, 1.0)
        while at < nxt - 1.0 and rng.random() < 0.7:
            words = []
            for _ in range(rng.randint(2, 12)):
                stop = at + rng.uniform(0.15, 0.5)
                if stop > nxt:
                    break
                words.append([rng.choice(WORDS), round(at, 3), round(stop, 3)])
                at = stop + rng.choice((0.0, 0.0, 0.05))
            if not words:
                break
            events.append({"t": words[0][1], "say": " ".join(w[0] for w in words), "words": words,
                           "stress": [rng.choice(words)[0]]})
            at += rng.uniform(0.3, 3.0)
        t = nxt
    events.append({"t": round(end, 3), "end": True})
    return events


def independent_check(model: Any, episode: dict[str, Any], signals: list[Any]) -> list[str]:
    """tests/independent_checker.py's verdict on an episode that ran as planned (empty: consistent)."""
    start = float(episode["start"])
    occurrences = [(s.id, round((s.start - start) * 1000), round((s.stop - start) * 1000)) for s in signals]
    return naive_problems(model, occurrences, round((float(episode["stop"]) - start) * 1000))


def one_dialogue(number: int, pool: list[str], args: argparse.Namespace, folder: Path) -> dict[str, Any]:
    rng = random.Random(args.seed * 1000 + number)
    events = make_script(pool, args.minutes, rng)
    script = folder / f"dialogue{number}.jsonl"
    script.write_text("".join(json.dumps(e) + "\n" for e in events))
    seed = args.seed + number
    report: dict[str, Any] = {"events": len(events), "minutes": args.minutes}

    # speed: the CLI, start-up included, then the planning alone in this process
    out = folder / f"dialogue{number}.json"
    began = time.perf_counter()
    subprocess.run([sys.executable, "-m", "mse", "live", str(script), "--seed", str(seed), "-o", str(out)],
                   check=True, env={**os.environ, "PYTHONPATH": str(REPO)})
    cli = time.perf_counter() - began
    parsed = read_script(script)
    session = Session(seed=seed, base=folder)
    for name in pool:  # load every set first: loading is not growth
        session.load(name)
    latencies: list[float] = []
    cpu_latencies: list[float] = []
    rss_at_5 = None
    began = time.perf_counter()
    for event in parsed:
        if rss_at_5 is None and event.t >= 300.0:
            rss_at_5 = rss_mb()
        tick, cpu_tick = time.perf_counter(), time.thread_time()
        handed = session.stream(event)
        if hasattr(event, "emotion"):
            new = session.current_episode
            first = next((s for s in handed if s.episode == new), None)
            if first is not None:  # an episode may have no occurrence at all: no latency to take
                latencies.append(time.perf_counter() - tick)
                cpu_latencies.append(time.thread_time() - cpu_tick)
        for _ in handed:
            pass
    planning = time.perf_counter() - began
    rss_end = rss_mb()
    timeline = session.timeline()
    same = plan_script(parsed, seed=seed, base=folder).to_json() == json.loads(out.read_text())
    report.update(cli_x_real_time=args.minutes * 60 / cli, planning_x_real_time=args.minutes * 60 / planning,
                  rss_growth_mb=rss_end - (rss_at_5 or rss_end), cli_equals_session=same,
                  latency_p50_ms=1000 * statistics.median(latencies),
                  latency_p99_ms=1000 * statistics.quantiles(latencies, n=100)[98],
                  latency_cpu_p50_ms=1000 * statistics.median(cpu_latencies),
                  latency_cpu_p99_ms=1000 * statistics.quantiles(cpu_latencies, n=100)[98])

    # consistency under the evaluator, episode by episode
    violations = check_dialogue(timeline)
    episodes = timeline.episodes
    report.update(episodes=len(episodes), announced=sum(1 for e in episodes if e["announced"]),
                  interrupted=sum(1 for e in episodes if e["interrupted"]),
                  episodes_with_violations=len({v.episode for v in violations}),
                  signals=len(timeline.signals), utterances=len(timeline.utterances))

    # independent checker and rates, per announced episode that ran as planned
    by_episode: dict[int, list[Any]] = defaultdict(list)
    for signal in timeline.signals:
        by_episode[signal.episode or 0].append(signal)
    models = {name: load(name if not name.endswith(".xml") else folder / name) for name in pool}
    independent_ok = independent_total = 0
    lengths: dict[str, list[float]] = defaultdict(list)
    counts: dict[str, int] = defaultdict(int)
    # The same script planned with --rate-seeds session seeds: rates as precise as the baseline's.
    replans = [timeline, *(plan_script(parsed, seed=seed + 1000 * k, base=folder) for k in range(1, args.rate_seeds))]
    for other in replans:
        for episode in other.episodes:
            if episode["announced"] and not episode["interrupted"]:
                counts[episode["emotion"]] += sum(1 for s in other.signals if s.episode == episode["index"])
    for episode in episodes:
        if not episode["announced"] or episode["interrupted"]:
            continue
        name = episode["emotion"]
        signals = by_episode[episode["index"]]
        length = float(episode["stop"]) - float(episode["start"])
        lengths[name] += [length] * args.rate_seeds
        independent_total += 1
        found = independent_check(models[name], episode, signals)
        independent_ok += not found
        if found:
            print(f"naive checker: episode {episode['index']} ({name}): {found}", file=sys.stderr)
    report.update(independent_checked=independent_total, independent_consistent=independent_ok)
    report["_lengths"], report["_counts"], report["_models"] = lengths, counts, models
    return report


def rates(reports: list[dict[str, Any]]) -> dict[str, Any]:
    """Occurrences per minute of each set's announced episodes, pooled over the dialogues,
    against the same set sampled alone at the same lengths (8 seeds each)."""
    from mse.sampling import sample

    lengths: dict[str, list[float]] = defaultdict(list)
    counts: dict[str, int] = defaultdict(int)
    models: dict[str, Any] = {}
    for report in reports:
        for name, spans in report.pop("_lengths").items():
            lengths[name] += spans
        for name, count in report.pop("_counts").items():
            counts[name] += count
        models.update(report.pop("_models"))
    result: dict[str, Any] = {}
    total_dialogue = total_alone = 0.0
    for name, spans in sorted(lengths.items()):
        alone = sum(len(sample(models[name], length, seed=10_000 + n).signals)  # type: ignore[union-attr]
                    for n, length in enumerate(spans))
        minutes = sum(spans) / 60
        result[name] = {"episodes": len(set(spans)), "dialogue": round(counts[name] / minutes, 2),
                        "alone": round(alone / minutes, 2), "ratio": round(counts[name] / alone, 3)}
        total_dialogue += counts[name]
        total_alone += alone
    result["all sets"] = {"ratio": round(total_dialogue / total_alone, 3)}
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--dialogues", type=int, default=1)
    parser.add_argument("--minutes", type=float, default=60.0)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--rate-seeds", type=int, default=8,
                        help="plan each script with this many session seeds for the rates (default 8)")
    args = parser.parse_args()
    print(f"load average {os.getloadavg()[0]:.2f} (2 cores, shared)")
    with tempfile.TemporaryDirectory() as temporary:
        folder = Path(temporary)
        greta = import_greta(folder / "greta")
        pool = [*bundled_names(), *(f"greta/{p.name}" for p in greta)]
        print(f"{len(pool)} sets: {len(bundled_names())} bundled ({behaviour_sets_dir()}), {len(greta)} from Greta")
        reports = []
        for number in range(args.dialogues):
            reports.append(one_dialogue(number, pool, args, folder))
            print(json.dumps({k: v for k, v in reports[-1].items() if not k.startswith("_")}), flush=True)
        print("occurrences per minute, announced episodes:", json.dumps(rates(reports), indent=1))
    print(f"load average {os.getloadavg()[0]:.2f} (2 cores, shared)")


if __name__ == "__main__":
    main()

"""Benchmark of `mse serve` (issue 29), on loopback only.  Prints numbers; asserts nothing.

    python -m bench.speed.serve                           # every part, about two minutes
    python -m bench.speed.serve --events 300 --concurrent 50 --seconds 20 --minutes 60 --sessions 500

The server runs as `mse serve --port 0` in a subprocess (its RSS read from /proc); the clients
are the `websockets` asyncio client in this process.  Every loop is bounded and stops by itself.

- latency, 1 session (real clock): from sending an emotion event to receiving the first
  occurrence of its new episode, p50/p99 over ``--events`` events, each emotion drawn from the
  bundled sets (every set is loaded before measuring);
- latency, ``--concurrent`` sessions each sending an event a second for ``--seconds`` seconds
  (target p99 <= 50 ms; 1 session: <= 30 ms);
- a ``--minutes``-long dialogue on the script clock (emotion changes every 2-20 s, utterances
  between, some announced): wall time, every episode of the assembled timeline checked
  (`mse.dialogue.check.check_dialogue` on the `{"type": "timeline"}` answer), server RSS at
  minute 5 and at the end (target growth <= 10 MB);
- ``--sessions`` sessions opened, given an event, and closed in a row: server RSS after the
  first 50 and at the end (target: no growth).
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import random
import re
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from websockets.asyncio.client import ClientConnection, connect

from mse.dialogue.check import check_dialogue
from mse.resources import bundled_names
from mse.timeline import Timeline

REPO = Path(__file__).resolve().parents[2]
WORDS = ("well", "I", "really", "do", "not", "know", "what", "you", "expected", "me", "to", "say")


def rss_mb(pid: int) -> float:
    with open(f"/proc/{pid}/statm") as handle:
        return int(handle.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def cpu_seconds(pid: int) -> float:
    """User and system CPU time of process ``pid`` so far."""
    with open(f"/proc/{pid}/stat") as handle:
        fields = handle.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))]


def start_server() -> tuple[subprocess.Popen[str], str]:
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    process = subprocess.Popen(
        [sys.executable, "-m", "mse", "serve", "--port", "0", "--quiet", "--max-rate", "10000",
         "--max-sessions", "200"],
        cwd=REPO, env=env, stdout=subprocess.PIPE, text=True)
    assert process.stdout is not None
    match = re.search(r"(ws://\S+)", process.stdout.readline())
    if match is None:
        process.kill()
        raise SystemExit("mse serve did not start")
    return process, match.group(1)


async def exchange(socket: ClientConnection, message: dict[str, Any]) -> list[dict[str, Any]]:
    """Send ``message``; what it brings up to its ack (an error raises)."""
    await socket.send(json.dumps(message))
    answer = []
    while True:
        out = json.loads(await asyncio.wait_for(socket.recv(), 60))
        if out["type"] == "error":
            raise RuntimeError(f"{message}: {out}")
        if out["type"] == "ack":
            return answer
        answer.append(out)


async def timed_event(socket: ClientConnection, emotion: str, seen: int) -> tuple[float, int]:
    """Seconds from sending an emotion to its episode's first occurrence; the new episode."""
    sent = time.perf_counter()
    await socket.send(json.dumps({"emotion": emotion}))
    first: float | None = None
    newest = seen
    while True:
        out = json.loads(await asyncio.wait_for(socket.recv(), 60))
        if out["type"] == "error":
            raise RuntimeError(str(out))
        if out["type"] == "occurrence" and out["episode"] > seen:
            newest = max(newest, out["episode"])
            if first is None:
                first = time.perf_counter() - sent
        if out["type"] == "ack":
            # a set may plan nothing for a while (an empty episode): count to the ack then
            return (first if first is not None else time.perf_counter() - sent), newest


async def one_session(uri: str, events: int, rng: random.Random) -> list[float]:
    names = bundled_names()
    async with connect(uri, max_size=None) as socket:
        await exchange(socket, {"type": "hello", "seed": 1})
        seen = -1
        for name in names:  # every set loaded before measuring
            _, seen = await timed_event(socket, name, seen)
        latencies = []
        for _ in range(events):
            latency, seen = await timed_event(socket, rng.choice(names), seen)
            latencies.append(latency)
            await asyncio.sleep(0.02)
        return latencies


async def paced_session(uri: str, seconds: float, rng: random.Random, ready: asyncio.Barrier) -> list[float]:
    names = bundled_names()
    async with connect(uri, max_size=None) as socket:
        await exchange(socket, {"type": "hello", "seed": rng.randrange(1000)})
        seen = -1
        for name in names:
            _, seen = await timed_event(socket, name, seen)
        await ready.wait()
        await asyncio.sleep(rng.random())  # the sessions' events spread over each second
        latencies = []
        start = time.perf_counter()
        tick = 0
        while time.perf_counter() - start < seconds:
            latency, seen = await timed_event(socket, rng.choice(names), seen)
            latencies.append(latency)
            tick += 1
            await asyncio.sleep(max(0.0, start + tick - time.perf_counter()))
        return latencies


async def concurrent(uri: str, sessions: int, seconds: float, seed: int) -> list[float]:
    ready = asyncio.Barrier(sessions)
    results = await asyncio.gather(*(paced_session(uri, seconds, random.Random(seed + i), ready)
                                     for i in range(sessions)))
    return [value for latencies in results for value in latencies]


def hour_script(minutes: float, rng: random.Random) -> list[dict[str, Any]]:
    names = bundled_names()
    events: list[dict[str, Any]] = []
    t = 0.0
    end = minutes * 60
    while t < end - 25:
        length = round(rng.uniform(2, 20), 3)
        event: dict[str, Any] = {"t": round(t, 3), "emotion": rng.choice(names),
                                 "intensity": round(rng.uniform(0.3, 1), 2)}
        if rng.random() < 0.5:
            event["until"] = round(t + length, 3)
        events.append(event)
        if rng.random() < 0.6:
            text = " ".join(rng.choice(WORDS) for _ in range(rng.randint(2, 8)))
            events.append({"t": round(t + rng.uniform(0.1, length / 3), 3), "say": text})
        t += length
    events.append({"t": round(t, 3), "end": True})
    return events


async def long_dialogue(uri: str, pid: int, minutes: float, seed: int) -> None:
    events = hour_script(minutes, random.Random(seed))
    async with connect(uri, max_size=None) as socket:
        await exchange(socket, {"type": "hello", "seed": seed, "clock": "script", "keep": True})
        start = time.perf_counter()
        await exchange(socket, events[0])
        rss_5 = None
        occurrences = 0
        for event in events[1:]:
            answer = await exchange(socket, event)
            occurrences += sum(1 for m in answer if m["type"] == "occurrence")
            if rss_5 is None and event["t"] >= 300:
                rss_5 = rss_mb(pid)
        wall = time.perf_counter() - start
        rss_end = rss_mb(pid)
        (whole,) = await exchange(socket, {"type": "timeline"})
    timeline = Timeline.from_json(whole["timeline"])
    problems = check_dialogue(timeline)
    episodes = timeline.episodes
    announced = sum(1 for e in episodes if e.get("announced"))
    print(f"{minutes:g}-minute dialogue, script clock: {len(events)} events, {len(episodes)} episodes "
          f"({announced} announced), {occurrences} occurrences sent in {wall:.1f} s "
          f"({minutes * 60 / wall:.0f}x real time)")
    print(f"  consistency: {len(problems)} problems over {len(episodes)} episodes (check_dialogue)")
    if rss_5 is not None:
        print(f"  server RSS: minute 5 {rss_5:.1f} MB, end {rss_end:.1f} MB, growth {rss_end - rss_5:+.1f} MB "
              "(the session keeps its whole timeline: keep true)")


async def churn(uri: str, pid: int, sessions: int) -> None:
    names = bundled_names()
    marks: dict[int, float] = {}
    start = time.perf_counter()
    for i in range(sessions):
        async with connect(uri, max_size=None) as socket:
            await exchange(socket, {"type": "hello", "seed": i, "clock": "script"})
            await exchange(socket, {"t": 0, "emotion": names[i % len(names)]})
            await exchange(socket, {"t": 5, "end": True})
        if i + 1 in (50, sessions):
            await asyncio.sleep(0.2)  # the server frees the session after the close
            marks[i + 1] = rss_mb(pid)
    wall = time.perf_counter() - start
    print(f"{sessions} sessions opened and closed in a row: {sessions / wall:.0f} a second; server RSS after 50 "
          f"{marks[50]:.1f} MB, after {sessions} {marks[sessions]:.1f} MB, growth "
          f"{marks[sessions] - marks[50]:+.1f} MB")


def report(label: str, latencies: list[float], target: float) -> None:
    ms = [1000 * v for v in latencies]
    p99 = percentile(ms, 0.99)
    print(f"{label}: {len(ms)} events, event -> first occurrence p50 {statistics.median(ms):.1f} ms, "
          f"p99 {p99:.1f} ms, max {max(ms):.1f} ms "
          f"(target p99 <= {target:g} ms: {'met' if p99 <= target else 'NOT met'})")


async def main_async(args: argparse.Namespace) -> None:
    process, uri = start_server()
    try:
        print(f"server {uri} (pid {process.pid}), load average {os.getloadavg()[0]:.2f}")
        if "latency" in args.parts:
            report("1 session", await one_session(uri, args.events, random.Random(args.seed)), 30)
        if "concurrent" in args.parts:
            server_cpu, own_cpu, wall = cpu_seconds(process.pid), time.process_time(), time.perf_counter()
            latencies = await concurrent(uri, args.concurrent, args.seconds, args.seed)
            server_cpu, own_cpu = cpu_seconds(process.pid) - server_cpu, time.process_time() - own_cpu
            wall = time.perf_counter() - wall
            report(f"{args.concurrent} sessions, an event a second each", latencies, 50)
            print(f"  CPU over the {wall:.1f} s (sets loaded included): server {server_cpu:.1f} s "
                  f"({100 * server_cpu / wall:.0f} % of one core), the clients {own_cpu:.1f} s; "
                  f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
        if "hour" in args.parts:
            await long_dialogue(uri, process.pid, args.minutes, args.seed)
        if "churn" in args.parts:
            await churn(uri, process.pid, args.sessions)
        print(f"load average {os.getloadavg()[0]:.2f}")
    finally:
        process.terminate()
        process.wait(30)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--parts", nargs="+", default=["latency", "concurrent", "hour", "churn"],
                        choices=["latency", "concurrent", "hour", "churn"])
    parser.add_argument("--events", type=int, default=300)
    parser.add_argument("--concurrent", type=int, default=50)
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--minutes", type=float, default=60.0)
    parser.add_argument("--sessions", type=int, default=500)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args(argv)
    asyncio.run(main_async(args))
    return 0


if __name__ == "__main__":
    sys.exit(main())

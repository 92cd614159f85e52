"""Benchmark of ``mse render`` (issue 16: 10 s at 25 fps in at most 10 s).  Prints numbers;
asserts nothing.

    python -m bench.speed.render                # 10 s of embarrassment, 960x540, 25 fps
    python -m bench.speed.render --formats mp4 webm gif --size 640x360 --repeat 3
    python -m bench.speed.render --view face    # the face view (default: half-body)

For each format: the wall time of ``mse render TIMELINE -o clip.FMT`` as a user runs it (a
subprocess: start-up, lexeme tables, painting, encoding, atomic write), and in this process
the wall and CPU time of :func:`mse.export.video.write_video` (CPU time counts the encoder's
threads; other processes on this shared machine disturb it less than the wall clock).
Baselines measured in the same run: painting every frame without encoding (in the chosen view
and in the other one), and encoding one
already painted frame as many times without painting (the encoder's own cost).  The load
average before and after says how busy the machine was.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from bench.baseline import run_python
from mse.api import load
from mse.export import ExportOptions
from mse.export.face.body import VIEWS
from mse.export.video import DEFAULT_VIEW, VideoOptions, _encode, frame_times, iter_frames, painter, write_video
from mse.sampling import sample
from mse.timeline import Timeline


def _timed(action: object) -> tuple[float, float]:
    wall, cpu = time.perf_counter(), time.process_time()
    action()  # type: ignore[operator]
    return time.perf_counter() - wall, time.process_time() - cpu


def _cli(timeline_path: Path, out: Path, size: str, fps: float, view: str) -> float:
    command = ["-m", "mse", "render", str(timeline_path), "-o", str(out), "--size", size, "--fps", str(fps)]
    command += ["--view", view]
    began = time.perf_counter()
    run_python(None, command, check=True)
    return time.perf_counter() - began


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--expression", default="embarrassment")
    parser.add_argument("--duration", type=float, default=10.0)
    parser.add_argument("--fps", type=float, default=25.0)
    parser.add_argument("--size", default="960x540")
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--formats", nargs="+", default=["mp4", "webm"])
    parser.add_argument("--view", choices=VIEWS, default=DEFAULT_VIEW)
    args = parser.parse_args()
    width, height = (int(v) for v in args.size.split("x"))
    video = VideoOptions(size=(width, height), fps=args.fps, view=args.view)
    other = VideoOptions(size=(width, height), fps=args.fps, view=next(v for v in VIEWS if v != args.view))
    result = sample(load(args.expression), args.duration, seed=args.seed)
    assert isinstance(result, Timeline)
    timeline = result
    frames_count = len(frame_times(timeline.duration, args.fps))
    print(f"{args.expression}, {args.duration:g} s, seed {args.seed}: {len(timeline.signals)} occurrences")
    print(f"{frames_count} frames of {args.size} at {args.fps:g} fps; load average before: {os.getloadavg()}")
    print(f"cores: {os.cpu_count()}; repeats: {args.repeat} (median and best of each)")

    with tempfile.TemporaryDirectory(prefix="mse-bench-render-") as folder:
        work = Path(folder)
        timeline_path = work / "t.json"
        timeline_path.write_text(timeline.dumps(), encoding="utf-8")
        frames = painter(timeline, ExportOptions(), video)
        times = frame_times(timeline.duration, args.fps)

        def paint_only(video: VideoOptions = video) -> None:
            for _ in iter_frames(painter(timeline, ExportOptions(), video), times):
                pass

        still = frames.paint(float(times[len(times) // 2]))

        def encode_only() -> None:
            _encode(iter(still for _ in times), work / "still.mp4", "mp4", video)

        rows = []
        steps = (
            (f"paint only, {args.view} (baseline)", paint_only),
            (f"paint only, {other.view}", lambda: paint_only(other)),
            ("encode only, mp4 (baseline)", encode_only),
        )
        for name, action in steps:
            runs = [_timed(action) for _ in range(args.repeat)]
            rows.append((name, runs))
        paint_wall = statistics.median(w for w, _ in rows[0][1])
        for fmt in args.formats:
            out = work / f"clip.{fmt}"

            def render(fmt: str = fmt, out: Path = out) -> None:
                write_video(timeline, out, fmt, ExportOptions(), video)

            rows.append((f"write_video {fmt}", [_timed(render) for _ in range(args.repeat)]))
            cli = [_cli(timeline_path, out, args.size, args.fps, args.view) for _ in range(args.repeat)]
            rows.append((f"mse render -o clip.{fmt}", [(wall, float("nan")) for wall in cli]))

        print()
        print(f"{'step':34} {'wall median':>12} {'wall best':>10} {'CPU median':>11} {'ms/frame':>9} {'x paint':>8}")
        for name, runs in rows:
            walls = [w for w, _ in runs]
            cpus = [c for _, c in runs]
            wall = statistics.median(walls)
            cpu = f"{statistics.median(cpus):10.2f}s" if not np.isnan(cpus[0]) else f"{'-':>11}"
            print(
                f"{name:34} {wall:11.2f}s {min(walls):9.2f}s {cpu} "
                f"{1000 * wall / frames_count:8.1f} {wall / paint_wall:8.2f}"
            )
    print()
    print(f"load average after: {os.getloadavg()}")
    print(f"target: {args.duration:g} s at {args.fps:g} fps in at most {args.duration:g} s (the mse render rows)")


if __name__ == "__main__":
    main()

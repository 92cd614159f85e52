"""Turning locomotion: real clips bent along a curve, and how a method's turning walks measure.

    python -m bench.evaluation.turning --library ../shared/motion/bandai-ds2 --methods hsmm
    python -m bench.evaluation.turning --library ../shared/motion/bandai-ds2 --deg-per-s 20 --factors 1,2,3

../shared holds no turning walk (Bandai dataset 2's ``walk-turn-left`` and ``-right`` are not
in it), so :func:`curved` makes them from the straight walks it holds: each frame turns the
root about the vertical by the distance it covers (``--deg-per-s`` over the clip) and the
root's horizontal steps with it (the path becomes an arc of the same speed; the feet stay
planted up to the turn of one frame, 0.7 deg at 20 deg/s and 30 fps). A turning library
holds one action, ``turn``, of those clips (the name tells the methods nothing; they measure
the turn from the clips). For each style and length factor the bench prints, real takes
against the method: steps per second and speed along the path (both in the path's heading
frame, :mod:`mse.motion.base.heading`), the turn's rate and total angle, the share of frames
and the largest distance the root moves against the direction of travel (which follows the
heading).
"""

from __future__ import annotations

import argparse
import sys
import warnings
from collections.abc import Sequence

import numpy as np

from mse.motion.base.bodyparts import body_map
from mse.motion.base.bvh import Motion
from mse.motion.base.contacts import find_root_joint
from mse.motion.base.heading import facing_yaws, heading_track, in_heading_frame, turned_along
from mse.motion.base.library import Clip, MotionLibrary, load_library

TURN_ACTION = "turn"


def curved(motion: Motion, rate: float) -> Motion:
    """``motion`` turning about the vertical as it goes, ``rate`` radians per second over the
    clip, each frame by the distance its root covers (a steady curve: a walker who stands at
    the start does not pivot in place)."""
    root = find_root_joint(motion)
    covered = np.linalg.norm(np.diff(motion.positions()[:, root][:, [0, 2]], axis=0), axis=1)
    distance = np.concatenate([[0.0], np.cumsum(covered)])
    total = rate * (motion.frame_count - 1) * motion.frame_time
    return turned_along(motion, total * distance / max(float(distance[-1]), 1e-9))


def turning_library(
    source: MotionLibrary, action: str, rate: float, styles: Sequence[str] | None = None
) -> MotionLibrary:
    """The clips of ``action`` in ``source`` (of ``styles``), bent by :func:`curved`, as one
    action :data:`TURN_ACTION` of an in-memory library."""
    clips, motions = [], {}
    for clip in source.select(action):
        if styles is not None and clip.style not in styles:
            continue
        turned_clip = Clip(f"turn-{clip.id}", TURN_ACTION, clip.style, clip.performer, f"curved:{clip.id}")
        clips.append(turned_clip)
        motions[turned_clip.id] = curved(source.motion(clip), rate)
    fingerprint = f"{source.content_hash}|{rate!r}"
    return MotionLibrary(f"{source.name}-turning", tuple(clips), preloaded=motions, fingerprint=fingerprint)


def turning_measures(motion: Motion) -> dict[str, float]:
    """Steps per second and speed along the path, the turn (deg/s, deg over the clip), and
    the share of frames and largest distance (file units) the root moves against the
    direction of travel, all in the path's heading frame."""
    body = body_map(motion.skeleton)
    positions = motion.positions()
    dt = motion.frame_time
    track = heading_track(motion, positions)
    raw = facing_yaws(positions, body.left_hip, body.right_hip)
    root = 0.5 * (positions[:, body.left_hip] + positions[:, body.right_hip])
    moves = in_heading_frame(np.diff(root[:, [0, 2]], axis=0), 0.5 * (track[1:] + track[:-1]))
    travel = moves.sum(axis=0)
    direction = travel / max(float(np.linalg.norm(travel)), 1e-9)
    along = moves @ direction
    from bench.evaluation.fidelity import step_rate_along_path

    separation = positions[:, body.left_foot][:, [0, 2]] - positions[:, body.right_foot][:, [0, 2]]
    span = max(motion.duration - dt, dt)
    return {
        "steps_per_s": step_rate_along_path(separation, track, dt),
        "speed": float(np.linalg.norm(travel)) / span,
        "turn_deg_per_s": float(np.degrees(np.polyfit(np.arange(raw.size) * dt, raw, 1)[0])),
        "turn_deg": float(np.degrees(track[-1] - track[0])),
        "backward_share": float(np.mean(along < 0)),
        "backward_max": float(max(0.0, -float(along.min()))),
    }


def _row(label: str, values: dict[str, float]) -> str:
    return (
        f"  {label:26s} steps/s {values['steps_per_s']:4.2f}  speed {values['speed']:6.1f}  "
        f"turn {values['turn_deg_per_s']:6.1f} deg/s {values['turn_deg']:7.1f} deg  "
        f"backward {100 * values['backward_share']:4.1f}% max {values['backward_max']:.2f}"
    )


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--library", required=True)
    parser.add_argument("--action", default="walk", help="the straight action to bend (default walk)")
    parser.add_argument("--deg-per-s", type=float, default=20.0)
    parser.add_argument("--styles", help="comma-separated (default: all)")
    parser.add_argument("--methods", default="hsmm")
    parser.add_argument("--factors", default="1,2,3")
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore")
    from mse.motion.generator import GenerationRequest, generator_for

    styles = args.styles.split(",") if args.styles else None
    library = turning_library(load_library(args.library), args.action, np.radians(args.deg_per_s), styles)
    if not library.clips:
        print(f"no clip of {args.action!r}", file=sys.stderr)
        return 1
    generators = {m: generator_for(m, None) for m in args.methods.split(",")}
    for style in sorted({c.style for c in library.clips}):
        own = [library.motion(c) for c in library.select(TURN_ACTION, style)]
        real = [turning_measures(m) for m in own]
        print(f"== {style} ({len(own)} takes)")
        for name in ("steps_per_s", "speed", "turn_deg_per_s", "turn_deg", "backward_max"):
            values = [r[name] for r in real]
            print(f"  real {name:16s} {min(values):8.2f} .. {max(values):8.2f}")
        length = float(np.median([m.duration for m in own]))
        for method, generator in generators.items():
            for factor in (float(f) for f in args.factors.split(",")):
                motion = generator.generate(library, GenerationRequest(TURN_ACTION, style, factor * length))
                print(_row(f"{method} x{factor:g} ({factor * length:.1f} s)", turning_measures(motion)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())


def walk_takes(source: MotionLibrary, styles: Sequence[str], per_style: int = 4) -> MotionLibrary:
    """The first ``per_style`` walk takes (by id) of each style: the straight walks the turning
    benches and tests bend."""
    keep = [c for style in styles for c in sorted(source.select("walk", style), key=lambda c: c.id)[:per_style]]
    return MotionLibrary("walks", tuple(keep))

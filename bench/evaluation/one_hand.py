"""One-hand waves: real two-hand waves with one arm at rest, and whether a method's waves
keep swinging at every length.

    python -m bench.evaluation.one_hand --library ../shared/motion/bandai-ds2 --methods hsmm

../shared holds no one-hand wave (Bandai dataset 2's ``wave-left-hand`` and
``wave-right-hand`` are not in it), so :func:`one_handed` makes them from its
``wave-both-hands`` takes: the left arm keeps the take's first pose (the rest pose before the
wave rises) and the right one waves. For each style and length factor the bench prints, real
takes against the method: the waving hand's swings per second and amplitude (the fidelity
bench's wave measures, on that hand alone) and the longest interval without a turn of the
sway (a wave that freezes holds still for seconds: HSMM's one-hand wave, when the action was
one block, swung twice, held about 3.5 s, swung once).
"""

from __future__ import annotations

import argparse
import warnings
from collections.abc import Sequence

import numpy as np

from bench.evaluation.fidelity import _wave
from mse.motion.base.body_frame import body_of
from mse.motion.base.bodyparts import limb_groups
from mse.motion.base.bvh import Motion
from mse.motion.base.cycles import detrended_sway, step_boundaries
from mse.motion.base.library import Clip, MotionLibrary, load_library

ONE_HAND_ACTION = "one-hand"


def one_handed(motion: Motion) -> Motion:
    """``motion`` with its left arm's rotations held at the first frame's."""
    skeleton = motion.skeleton
    values = motion.values.copy()
    for joint in limb_groups(skeleton)["left_arm"]:
        columns = list(skeleton.rotation_columns(joint))
        values[:, columns] = values[:1, columns]
    return motion.with_values(values)


def one_hand_library(source: MotionLibrary, action: str, styles: Sequence[str] | None = None) -> MotionLibrary:
    """The clips of ``action`` (of ``styles``) made one-handed, as one action
    :data:`ONE_HAND_ACTION` of an in-memory library."""
    clips, motions = [], {}
    for clip in source.select(action):
        if styles is not None and clip.style not in styles:
            continue
        made = Clip(f"one-{clip.id}", ONE_HAND_ACTION, clip.style, clip.performer, f"one-hand:{clip.id}")
        clips.append(made)
        motions[made.id] = one_handed(source.motion(clip))
    return MotionLibrary(f"{source.name}-one-hand", tuple(clips), preloaded=motions, fingerprint=source.content_hash)


def wave_measures(motion: Motion) -> dict[str, float]:
    """The right (waving) hand's swings per second and amplitude against the chest, and the
    longest time (s) between two turns of its sway, or from the clip's edges to them."""
    data = body_of(motion)
    p, dt = data.positions, data.frame_time
    side = p[:, data.body.right_hand, 0] - p[:, data.chest, 0]
    frequency, amplitude = _wave(side, dt)
    sway = detrended_sway(side[:, None], dt)
    turns = step_boundaries(sway, max(2, round(0.2 / dt)))
    edges = [0, *turns, len(side) - 1]
    return {"frequency": frequency, "amplitude": amplitude, "longest_hold_s": float(np.max(np.diff(edges))) * dt}


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--library", required=True)
    parser.add_argument("--action", default="wave-both-hands")
    parser.add_argument("--styles")
    parser.add_argument("--methods", default="hsmm")
    parser.add_argument("--factors", default="1,2,3")
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore")
    from mse.motion.generator import GenerationRequest, generator_for

    styles = args.styles.split(",") if args.styles else None
    library = one_hand_library(load_library(args.library), args.action, styles)
    generators = {m: generator_for(m, None) for m in args.methods.split(",")}
    for style in sorted({c.style for c in library.clips}):
        own = [library.motion(c) for c in library.select(ONE_HAND_ACTION, style)]
        real = [wave_measures(m) for m in own]
        spans = {k: (min(r[k] for r in real), max(r[k] for r in real)) for k in real[0]}
        ranges = "  ".join(f"{k} {a:.2f}..{b:.2f}" for k, (a, b) in spans.items())
        print(f"== {style} ({len(own)} takes) real: {ranges}")
        length = float(np.median([m.duration for m in own]))
        for method, generator in generators.items():
            for factor in (float(f) for f in args.factors.split(",")):
                request = GenerationRequest(ONE_HAND_ACTION, style, factor * length)
                values = wave_measures(generator.generate(library, request))
                print(f"  {method} x{factor:g}: " + "  ".join(f"{k} {v:.2f}" for k, v in values.items()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

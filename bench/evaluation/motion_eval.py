"""Objective validation of the LMA + HMM generation on Bandai dataset 1 (paper §IV-D, §V-A).

    python -m bench.evaluation.motion_eval [--data ../shared/motion/bandai-ds1] [--actions bow,bye,...]

Leave-one-performance-out: each clip of the chosen actions in the styles normal, happy, sad,
angry, proud, not-confident, tired, active is the desired path; it is generated in every
other of those styles from a library without it; the result is classified by a recognizer
trained on the real clips only (also without it). Prints the recognizer's own accuracy on the
real clips, the recognition rate and confusion matrix of the generated clips, and per-stage
times (LMA features, RMLR, NN search, HMM fit, Viterbi, total per leaf), plus the targets:
LMA of a 5 s clip, NN search, a leaf with a warm cache.

Recognizer: :class:`bench.evaluation.recognize.StyleRecognizer` — the 27 LMA components plus
per-frame speed/acceleration/jerk statistics, posture in the body frame and timing, z-scored
within the clip's action, multinomial logistic regression with C by cross-validation on the
training clips. ``--styles angry,happy,sad,not-confident`` gives the paper's four-emotion
setting: conversions among those styles; the recognizer still learns all eight styles (seven
clips per action for its normalisation) and decides among the four.
"""

from __future__ import annotations

import argparse
import os
import time
import warnings
from collections import Counter, defaultdict
from pathlib import Path

import numpy as np

from bench.evaluation.recognize import MIN_ACTION_CLIPS, StyleRecognizer, style_descriptor
from mse.motion.base.library import Clip, MotionLibrary, load_library
from mse.motion.base.lma import lma_features
from mse.motion.lma_hmm.generate import GenerationParams, generate_motion
from mse.motion.lma_hmm.search import clip_features, nearest_neighbours, saliency_for

STYLES = ("normal", "happy", "sad", "angry", "proud", "not-confident", "tired", "active")
DEFAULT_ACTIONS = ("bow", "bye", "byebye", "guide")
#: the paper's four emotions (anger, happiness, fear, sadness); Bandai has no fear: the
#: emotion table maps fear to not-confident
FOUR_EMOTIONS = ("angry", "happy", "sad", "not-confident")
_DESCRIPTORS: dict[str, np.ndarray] = {}


def _descriptor(library: MotionLibrary, clip: Clip) -> np.ndarray:
    if clip.id not in _DESCRIPTORS:
        _DESCRIPTORS[clip.id] = style_descriptor(library.motion(clip), path=clip.source)
    return _DESCRIPTORS[clip.id]


def _train(library: MotionLibrary, clips: list[Clip], left_out: Clip) -> StyleRecognizer:
    """The recognizer on every real clip but ``left_out`` (which is the desired path)."""
    kept = [c for c in clips if c.id != left_out.id]
    table = np.array([_descriptor(library, c) for c in kept])
    return StyleRecognizer.fit(table, [c.action for c in kept], [c.style for c in kept])


def _confusion(pairs: list[tuple[str, str]], styles: tuple[str, ...]) -> str:
    lines = ["target \\ recognised " + " ".join(f"{s[:6]:>6}" for s in styles) + "   rate"]
    for target in styles:
        row = [sum(1 for t, r in pairs if t == target and r == s) for s in styles]
        total = sum(1 for t, _ in pairs if t == target)
        rate = f"{100 * row[styles.index(target)] / total:6.1f} %" if total else "      -"
        lines.append(f"{target:<20} " + " ".join(f"{n:>6}" for n in row) + " " + rate)
    return "\n".join(lines)


def _rate(pairs: list[tuple[str, str]]) -> float:
    return float(np.mean([t == r for t, r in pairs])) if pairs else 0.0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    shared = Path(os.environ.get("MSE_SHARED", Path(__file__).resolve().parents[3] / "shared"))
    parser.add_argument("--data", default=str(shared / "motion" / "bandai-ds1"))
    parser.add_argument("--actions", default=",".join(DEFAULT_ACTIONS))
    parser.add_argument(
        "--styles",
        default=",".join(STYLES),
        help=f"styles compared (the paper's four emotions: {','.join(FOUR_EMOTIONS)})",
    )
    parser.add_argument("--limit", type=int, default=0, help="at most this many desired paths")
    parser.add_argument("--states", type=int, default=GenerationParams().states, help="HMM states")
    parser.add_argument("--nd", type=int, default=GenerationParams().nd, help="copies of X_d")
    parser.add_argument(
        "--cutoff", type=float, default=GenerationParams().cutoff_hz, help="low-pass cut-off (Hz)"
    )
    parser.add_argument(
        "--regenerate",
        choices=("means", "frames"),
        default=GenerationParams().regenerate,
        help="output of the HMM: the paper's state means, or the neighbours' frames per state",
    )
    parser.add_argument(
        "--timing",
        choices=("desired", "target"),
        default="desired",
        help="length of a generated clip: the desired path's (the paper's) or the mean length "
        "of the target-style clips of the action (a schedule that gives the style its tempo)",
    )
    parser.add_argument(
        "--wide",
        action="store_true",
        help="also score the recognizer on the real clips of every action with enough clips",
    )
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    styles = tuple(args.styles.split(","))

    started = time.perf_counter()
    library = load_library(args.data)
    actions = args.actions.split(",")
    # the recognizer always learns all eight styles (7 other clips per action for its
    # per-action normalisation) and decides among ``styles``; conversions stay in ``styles``
    clips = [c for c in library.clips if c.style in STYLES]
    evaluated = [c for c in clips if c.action in actions and c.style in styles]
    if args.limit:
        evaluated = evaluated[: args.limit]
    clock = time.perf_counter()
    for clip in clips:
        clip_features(library, clip)
        _descriptor(library, clip)
    print(
        f"library: {len(library.clips)} clips; {len(clips)} in the 8 styles; "
        f"LMA + descriptors of all: {time.perf_counter() - clock:.1f} s (incl. BVH reading)"
    )

    # -- the recognizer's own accuracy on real clips (leave one out) ---------------------
    clock = time.perf_counter()
    recognizers = {clip.id: _train(library, clips, clip) for clip in evaluated}
    chance = 100 / len(styles)
    real_pairs = [
        (c.style, recognizers[c.id].predict(_descriptor(library, c), c.action, styles)) for c in evaluated
    ]
    print(
        f"\nrecognizer on real clips (leave one out, {len(real_pairs)} clips of "
        f"{','.join(actions)}): {100 * _rate(real_pairs):.1f} % (chance {chance:.1f} %; "
        f"{(time.perf_counter() - clock) / max(1, len(evaluated)):.2f} s per fit incl. CV of C)"
    )
    per_action = Counter(c.action for c in clips)
    wider = [
        c
        for c in clips
        if per_action[c.action] >= MIN_ACTION_CLIPS and c.id not in recognizers and c.style in styles
    ]
    if args.wide and wider:
        real_pairs = real_pairs + [
            (c.style, _train(library, clips, c).predict(_descriptor(library, c), c.action, styles))
            for c in wider
        ]
        print(
            f"recognizer on real clips (leave one out, all {len(real_pairs)} clips of actions "
            f"with >= {MIN_ACTION_CLIPS} clips): {100 * _rate(real_pairs):.1f} %"
        )
    print(_confusion(real_pairs, styles))

    # -- conversions -----------------------------------------------------------------------
    stage_times: dict[str, list[float]] = defaultdict(list)
    pairs: list[tuple[str, str]] = []
    neighbour_counts = []
    for number, clip in enumerate(evaluated, 1):
        recognizer = recognizers[clip.id]
        desired = library.motion(clip)
        for target in styles:
            if target == clip.style or not library.select(clip.action, target):
                continue
            duration = desired.duration
            if args.timing == "target":
                lengths = [library.motion(c).duration for c in library.select(clip.action, target)]
                duration = float(np.mean(lengths))
            result = generate_motion(
                library,
                clip.action,
                target,
                duration=duration,
                clip=clip.id,
                exclude=(clip.id,),
                params=GenerationParams(
                    states=args.states, nd=args.nd, cutoff_hz=args.cutoff, regenerate=args.regenerate
                ),
            )
            for stage, seconds in result.timings.items():
                stage_times[stage].append(seconds)
            neighbour_counts.append(len(result.neighbours))
            pairs.append((target, recognizer.predict(style_descriptor(result.motion), clip.action, styles)))
        print(f"  [{number}/{len(evaluated)}] {clip.id}: running rate {100 * _rate(pairs):.1f} %", flush=True)
    print(
        f"\nregenerate {args.regenerate}, cut-off {args.cutoff} Hz, timing {args.timing}: "
        f"generated clips: {len(pairs)} conversions, recognition rate "
        f"{100 * _rate(pairs):.1f} % (chance {chance:.1f} %; paper: 72 % over 4 emotions)"
    )
    print(f"neighbours per conversion: mean {np.mean(neighbour_counts):.2f}")
    print(_confusion(pairs, styles))

    print("\nper-stage times per leaf (cold cache for this desired path), mean / max:")
    for stage in ("lma", "rmlr", "nn_search", "hmm_fit", "viterbi", "filter", "total"):
        values = stage_times.get(stage, [0.0])
        print(f"  {stage:<10} {1000 * np.mean(values):9.1f} ms {1000 * np.max(values):9.1f} ms")

    # -- targets ---------------------------------------------------------------------------
    five = next(c for c in clips if library.motion(c).duration >= 5.0)
    motion = library.motion(five).slice(0, round(5.0 / library.motion(five).frame_time))
    lma_features(motion)
    clock = time.perf_counter()
    for _ in range(20):
        lma_features(motion)
    print(
        f"\nLMA features of a 5 s clip ({motion.frame_count} frames): "
        f"{1000 * (time.perf_counter() - clock) / 20:.1f} ms (target 20 ms)"
    )
    saliency = saliency_for(library, clips)
    candidates = np.array([clip_features(library, c) for c in clips])
    components = saliency.search_components("sad", "happy")
    clock = time.perf_counter()
    for _ in range(100):
        nearest_neighbours(candidates[0], candidates, components, saliency)
    print(
        f"NN search over {len(clips)} clips: {1000 * (time.perf_counter() - clock) / 100:.2f} ms "
        "(target 10 ms; paper 0.8 s)"
    )
    generate_motion(library, "bow", "sad", duration=2.0)
    clock = time.perf_counter()
    for duration in (1.5, 2.5, 3.5):
        generate_motion(library, "bow", "sad", duration=duration)
    print(f"leaf with a warm cache: {1000 * (time.perf_counter() - clock) / 3:.1f} ms (target 200 ms)")
    print(f"\nbench total: {time.perf_counter() - started:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

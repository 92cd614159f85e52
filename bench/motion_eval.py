"""Objective validation of the LMA + HMM generation on Bandai dataset 1 (paper §IV-D, §V-A).

    python bench/motion_eval.py [--data ../shared/motion/bandai-ds1] [--actions bow,bye,...]

Leave-one-performance-out: each clip of the chosen actions in the styles normal, happy, sad,
angry, proud, not-confident, tired, active is the desired path; it is generated in every
other of those styles from a library without it; the result is classified by a recognizer
trained on the real clips only (also without it). Prints the recognizer's own accuracy on the
real clips, the recognition rate and confusion matrix of the generated clips, and per-stage
times (LMA features, RMLR, NN search, HMM fit, Viterbi, total per leaf), plus the targets:
LMA of a 5 s clip, NN search, a leaf with a warm cache.

Recognizer: multinomial logistic regression (L2, C=0.3) on the 27 LMA components, log1p-
compressed, minus the mean of the clip's action over the training clips (style is a
modulation of an action), z-scored.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import warnings
from collections import defaultdict
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from mse.motion.generate import GenerationParams, generate_motion
from mse.motion.library import Clip, MotionLibrary, load_library
from mse.motion.lma import lma_features
from mse.motion.search import clip_features, nearest_neighbours, saliency_for

STYLES = ("normal", "happy", "sad", "angry", "proud", "not-confident", "tired", "active")
DEFAULT_ACTIONS = ("bow", "bye", "byebye", "guide")
#: chosen by leave-one-out accuracy on the real clips (C in 0.1, 0.3, 1, 3, 10 tried)
RECOGNIZER_C = 0.3


class Recognizer:
    def __init__(self, raw: np.ndarray, actions: list[str], styles: list[str]) -> None:
        from sklearn.linear_model import LogisticRegression

        logs = np.log1p(np.maximum(raw, 0.0))
        self.action_mean = {a: logs[[x == a for x in actions]].mean(axis=0) for a in set(actions)}
        centred = logs - np.array([self.action_mean[a] for a in actions])
        self.mean, self.scale = centred.mean(axis=0), centred.std(axis=0) + 1e-9
        self.model = LogisticRegression(C=RECOGNIZER_C, max_iter=3000)
        self.model.fit((centred - self.mean) / self.scale, styles)

    def predict(self, raw: np.ndarray, action: str) -> str:
        logs = np.log1p(np.maximum(raw, 0.0)) - self.action_mean[action]
        return str(self.model.predict(((logs - self.mean) / self.scale)[None, :])[0])


def _train(library: MotionLibrary, clips: list[Clip], left_out: Clip) -> Recognizer:
    kept = [c for c in clips if c.id != left_out.id]
    raw = np.array([clip_features(library, c) for c in kept])
    return Recognizer(raw, [c.action for c in kept], [c.style for c in kept])


def _confusion(pairs: list[tuple[str, str]]) -> str:
    lines = ["target \\ recognised " + " ".join(f"{s[:6]:>6}" for s in STYLES)]
    for target in STYLES:
        row = [sum(1 for t, r in pairs if t == target and r == s) for s in STYLES]
        lines.append(f"{target:<20} " + " ".join(f"{n:>6}" for n in row))
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    shared = Path(os.environ.get("MSE_SHARED", Path(__file__).resolve().parents[2] / "shared"))
    parser.add_argument("--data", default=str(shared / "motion" / "bandai-ds1"))
    parser.add_argument("--actions", default=",".join(DEFAULT_ACTIONS))
    parser.add_argument("--limit", type=int, default=0, help="at most this many desired paths")
    parser.add_argument("--states", type=int, default=12, help="HMM states")
    parser.add_argument("--nd", type=int, default=0, help="copies of the desired path")
    parser.add_argument("--cutoff", type=float, default=3.0, help="low-pass cut-off (Hz)")
    parser.add_argument(
        "--timing",
        choices=("desired", "target"),
        default="desired",
        help="length of a generated clip: the desired path's (the paper's) or the mean length "
        "of the target-style clips of the action (a schedule that gives the style its tempo)",
    )
    args = parser.parse_args()
    warnings.simplefilter("ignore")

    started = time.perf_counter()
    library = load_library(args.data)
    actions = args.actions.split(",")
    clips = [c for c in library.clips if c.style in STYLES]
    evaluated = [c for c in clips if c.action in actions]
    if args.limit:
        evaluated = evaluated[: args.limit]
    clock = time.perf_counter()
    for clip in clips:
        clip_features(library, clip)
    print(
        f"library: {len(library.clips)} clips; {len(clips)} in the 8 styles; LMA of all: "
        f"{time.perf_counter() - clock:.1f} s (incl. BVH reading)"
    )

    # -- the recognizer's own accuracy on real clips (leave one out) ---------------------
    real_pairs = []
    for clip in evaluated:
        recognizer = _train(library, clips, clip)
        real_pairs.append((clip.style, recognizer.predict(clip_features(library, clip), clip.action)))
    real_rate = np.mean([t == r for t, r in real_pairs])
    print(
        f"\nrecognizer on real clips (leave one out, {len(real_pairs)} clips): "
        f"{100 * real_rate:.1f} % (chance {100 / len(STYLES):.1f} %)"
    )

    # -- conversions -----------------------------------------------------------------------
    stage_times: dict[str, list[float]] = defaultdict(list)
    pairs: list[tuple[str, str]] = []
    neighbour_counts = []
    for number, clip in enumerate(evaluated, 1):
        recognizer = _train(library, clips, clip)
        desired = library.motion(clip)
        for target in STYLES:
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
                params=GenerationParams(states=args.states, nd=args.nd, cutoff_hz=args.cutoff),
            )
            for stage, seconds in result.timings.items():
                stage_times[stage].append(seconds)
            neighbour_counts.append(len(result.neighbours))
            features = lma_features(result.motion).vector()
            pairs.append((target, recognizer.predict(features, clip.action)))
        done = np.mean([t == r for t, r in pairs]) if pairs else 0.0
        print(f"  [{number}/{len(evaluated)}] {clip.id}: running rate {100 * done:.1f} %", flush=True)
    rate = np.mean([t == r for t, r in pairs])
    print(
        f"\ntiming {args.timing}: generated clips: {len(pairs)} conversions, recognition rate {100 * rate:.1f} % "
        f"(chance {100 / len(STYLES):.1f} %; paper: 72 % over 4 emotions)"
    )
    print(f"neighbours per conversion: mean {np.mean(neighbour_counts):.2f}")
    print(_confusion(pairs))

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

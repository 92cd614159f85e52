"""Evaluation of the HSMM stylistic synthesis (issue 7) on Bandai dataset 1 walks and bows.

    python bench/style_eval.py [--library ../shared/motion/bandai-ds1] [--actions walk bow]
                               [--shared-average]

For each action and each of the 15 styles, adapt the average model from ONE take of the
style, synthesize, and report:

(a) style recognition of synthesized vs original clips by a recognizer trained on real clips
    only (paper: 45.9 % original vs 38.9 % synthetic among 13 choices, human raters);
(b) the same for models trained from scratch on the same single take (adaptation must win);
(c) over-smoothing: per-joint global variance of synthesized / original, GV on and off;
(d) times: average training, adaptation, synthesis per second of motion, 5 s synthesis.

Protocol.  The average model for a style is trained on the other 14 styles (leave one style
out, so adaptation really starts from a model that never saw the style; ``--shared-average``
uses one model over all styles instead, faster).  Recognizer: 2 s windows (hop 0.5 s) of the
aligned exponential-map features described by mean, standard deviation and mean absolute
velocity per dimension, standardised, multinomial logistic regression (scikit-learn); a clip
is classified by the mean log-probability of its windows.  It is trained on take 001 of
every style.  Walk originals are tested on the held-out take 002; bows have one take per
style, so their "original" rate is measured on the training clips (an upper bound).
Synthesized clips have the length of the original they are compared with.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from mse.motion.bvh import Motion
from mse.motion.hsmm import api
from mse.motion.hsmm.features import FloatArray
from mse.motion.hsmm.prep import Template, build_template, static_features
from mse.motion.library import MotionLibrary, load_library

WINDOW, HOP = 60, 15


def window_descriptors(statics: FloatArray) -> FloatArray:
    frames = statics.shape[0]
    starts = range(0, max(1, frames - WINDOW + 1), HOP)
    rows = []
    for start in starts:
        chunk = statics[start : start + WINDOW]
        velocity = np.abs(np.diff(chunk, axis=0)).mean(axis=0) if len(chunk) > 1 else 0 * chunk[0]
        rows.append(np.concatenate([chunk.mean(axis=0), chunk.std(axis=0), velocity]))
    return np.asarray(rows)


class Recognizer:
    """Style classifier trained on real clips only."""

    def __init__(self, template: Template, clips: list[tuple[Motion, str]]) -> None:
        from sklearn.linear_model import LogisticRegression
        from sklearn.pipeline import make_pipeline
        from sklearn.preprocessing import StandardScaler

        self.template = template
        features, labels = [], []
        for motion, style in clips:
            rows = window_descriptors(static_features(motion, template))
            features.append(rows)
            labels.extend([style] * len(rows))
        self.model = make_pipeline(StandardScaler(), LogisticRegression(C=0.1, max_iter=2000))
        self.model.fit(np.concatenate(features), labels)
        self.classes = list(self.model.classes_)

    def window_accuracy(self, motion: Motion, style: str) -> float:
        rows = window_descriptors(static_features(motion, self.template))
        return float(np.mean(self.model.predict(rows) == style))

    def predict(self, motion: Motion) -> str:
        rows = window_descriptors(static_features(motion, self.template))
        scores = self.model.predict_log_proba(rows).mean(axis=0)
        return str(self.classes[int(np.argmax(scores))])


def joint_gv(motion: Motion, template: Template) -> FloatArray:
    statics = static_features(motion, template)
    result: FloatArray = statics.var(axis=0).reshape(-1, 3).sum(axis=1)
    return result


def evaluate(
    library: MotionLibrary, action: str, shared_average: bool, little: float | None = None
) -> None:
    clips = sorted(library.select(action=action), key=lambda c: c.id)
    styles = sorted({c.style for c in clips})
    takes = {s: [c for c in clips if c.style == s] for s in styles}
    adapt_clip = {s: library.motion(takes[s][0]) for s in styles}
    second = {s: library.motion(takes[s][1]) if len(takes[s]) > 1 else None for s in styles}
    template = build_template([library.motion(c) for c in clips])
    # The recognizer learns from real clips the models never see (take 002) when there are.
    disjoint = all(second[s] is not None for s in styles)
    recognizer = Recognizer(
        template,
        [(second[s] if disjoint else adapt_clip[s], s) for s in styles],  # type: ignore[misc]
    )
    amount = f"first {little:g} s of take 001" if little else "take 001"
    print(
        f"\n== {action}: {len(styles)} styles, {len(clips)} clips; adaptation data: {amount}; "
        f"chance {100 / len(styles):.1f} %"
    )
    data = {s: adapt_clip[s] for s in styles}
    if little:
        frames = round(little / adapt_clip[styles[0]].frame_time)
        data = {s: adapt_clip[s].slice(0, min(frames, adapt_clip[s].frame_count)) for s in styles}

    timings: dict[str, list[float]] = {"train": [], "adapt": [], "scratch": [], "synth_per_s": []}
    shared = None
    if shared_average:
        started = time.perf_counter()
        shared = api.train_average([(adapt_clip[s], s) for s in styles], action)
        timings["train"].append(time.perf_counter() - started)
    hits = {"original": 0, "adapted": 0, "scratch": 0}
    windows = {"original": 0.0, "adapted": 0.0, "scratch": 0.0}
    ratios_on: list[float] = []
    ratios_off: list[float] = []
    ratios_scratch: list[float] = []
    for style in styles:
        if shared is not None:
            average = shared
        else:
            others = [(adapt_clip[s], s) for s in styles if s != style]
            started = time.perf_counter()
            average = api.train_average(others, action)
            timings["train"].append(time.perf_counter() - started)
        started = time.perf_counter()
        adapted = api.adapt_model(average, [data[style]], style)
        timings["adapt"].append(time.perf_counter() - started)
        started = time.perf_counter()
        scratch = api.train_scratch([(data[style], style)], action)
        timings["scratch"].append(time.perf_counter() - started)

        original = adapt_clip[style]
        seconds = original.duration
        started = time.perf_counter()
        synth_on = api.synthesize(adapted, duration_s=seconds, seed=0)
        timings["synth_per_s"].append((time.perf_counter() - started) / seconds)
        synth_off = api.synthesize(adapted, duration_s=seconds, gv=False, seed=0)
        synth_scratch = api.synthesize(scratch, duration_s=seconds, seed=0)

        for key, clip in (
            ("original", original),
            ("adapted", synth_on),
            ("scratch", synth_scratch),
        ):
            hits[key] += recognizer.predict(clip) == style
            windows[key] += recognizer.window_accuracy(clip, style)
        real = joint_gv(adapt_clip[style], template)
        moving = real > 1e-4  # joints that actually move (Bandai's joint_Root never does)
        for bucket, clip in (
            (ratios_on, synth_on),
            (ratios_off, synth_off),
            (ratios_scratch, synth_scratch),
        ):
            bucket.append(np.median(joint_gv(clip, template)[moving] / real[moving]))

    n = len(styles)
    kind = "take 001, recognizer on take 002" if disjoint else "recognizer's own training clips"
    print("    recognition rate per clip (per 2 s window in brackets)")
    for label, key in (
        (f"(a) original ({kind})", "original"),
        ("    synthesized, adapted from the data", "adapted"),
        ("(b) synthesized, trained from scratch on the data", "scratch"),
    ):
        print(f"{label}: {100 * hits[key] / n:5.1f} % ({100 * windows[key] / n:5.1f} %)")
    print(
        f"(c) GV ratio synth/original, median over joints, mean over styles: "
        f"GV on {np.mean(ratios_on):.2f}, GV off {np.mean(ratios_off):.2f}, "
        f"scratch+GV {np.mean(ratios_scratch):.2f}"
    )
    print(f"    GV on: min {np.min(ratios_on):.2f} max {np.max(ratios_on):.2f}")
    print(
        f"(d) times: average training {np.mean(timings['train']):.2f} s "
        f"({'one model' if shared_average else 'per left-out style'}), adaptation "
        f"{np.mean(timings['adapt']):.2f} s, scratch training {np.mean(timings['scratch']):.2f} s, "
        f"synthesis {1000 * np.mean(timings['synth_per_s']):.1f} ms per second of motion"
    )
    reference = shared if shared is not None else average
    best = []
    for _ in range(5):
        started = time.perf_counter()
        api.synthesize(reference, duration_s=5.0)
        best.append(time.perf_counter() - started)
    print(f"    synthesis of 5 s: {1000 * min(best):.0f} ms (best of 5, GV on)")


def main() -> int:
    default = Path(os.environ.get("MSE_SHARED", Path(__file__).resolve().parents[2] / "shared"))
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--library", default=str(default / "motion" / "bandai-ds1"))
    parser.add_argument("--actions", nargs="+", default=["walk", "bow"])
    parser.add_argument("--shared-average", action="store_true")
    parser.add_argument(
        "--little",
        type=float,
        nargs="*",
        default=[0.0, 2.0],
        help="also adapt from only the first S seconds of the take (0: the whole take)",
    )
    args = parser.parse_args()
    library = load_library(args.library)
    with api.single_threaded_blas():
        for action in args.actions:
            for little in args.little:
                evaluate(library, action, args.shared_average, little or None)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

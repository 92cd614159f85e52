"""Evaluation of the HSMM stylistic synthesis (issue 7) on Bandai dataset 1 walks and bows.

    python bench/style_eval.py [--library ../shared/motion/bandai-ds1] [--actions walk bow]
                               [--budget 2 1 0] [--windows 3] [--one-fold] [--shared-average]

Question: does adapting the average model to a style from LITTLE data give clips whose style
is recognised better than a model trained from scratch on the SAME little data?  Reported
per action and amount of data: recognition of real clips, of clips synthesized by the
adapted model and by the scratch model, chance, and whether "adaptation beats scratch"
holds; then the over-smoothing ratio (GV on/off) and times.

Protocol (documented in docs/hsmm.md):

* Little data.  The adaptation data of a style is a window of ``--budget`` seconds (2 s is
  2.5-4 steps of a walk; the paper adapts from "about a dozen steps") cut from one take.
  Up to ``--windows`` disjoint windows per style and take (offsets 0, budget, 2·budget)
  are independent trials.  Budget 0, or a take shorter than two budgets, uses the whole
  take.  The scratch model is trained on exactly the same window with exactly the same
  training code (``api.train_scratch``: segmental k-means, same states, floor, iterations,
  GV) minus the average-model prior.
* Average model.  Trained on take 001 of the OTHER 14 styles (leave one style out), so it
  never saw the target style.  ``--shared-average`` trains one model over all 15 styles
  (faster, but it saw the style: a quick check only, never the verdict).
* Recognizer.  Trained on real clips only, never on a take that is evaluated: walks have two
  takes per style, so two folds are run (data from take 001, recognizer trained on take 002
  of every style; then the other way round; ``--one-fold`` keeps the first).  2 s windows
  (hop 0.5 s) of the aligned exponential-map features summarised by mean, standard
  deviation and mean absolute velocity per dimension, standardised, multinomial logistic
  regression; a clip gets the style with the best mean window log-probability.  Originals
  evaluated = the data takes; synthesized clips have the data take's length.  Bows have ONE
  take per style: there is no held-out real clip, so the bow recognizer is trained on the
  takes it evaluates; bow rates are printed for information, marked "NOT measurable
  held-out", and excluded from the verdict.
* Chance = 1 / number of styles.  Verdict: adapted vs scratch over all trials, per clip,
  with the paired count (trials only adaptation got right / only scratch got right) and a
  two-sided sign-test p-value; "HOLDS" needs a higher rate AND p < 0.05, a higher rate
  without significance is printed as "holds numerically only".
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from mse.motion.bvh import Motion
from mse.motion.hsmm import api
from mse.motion.hsmm.features import FloatArray
from mse.motion.hsmm.model import HsmmModel
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


def sign_test(wins: int, losses: int) -> float:
    """Two-sided exact sign test p-value of ``wins`` against ``losses`` (ties dropped)."""
    n = wins + losses
    if n == 0:
        return 1.0
    tail = sum(math.comb(n, k) for k in range(min(wins, losses) + 1)) / float(2**n)
    return float(min(1.0, 2.0 * tail))


@dataclass
class Tally:
    """Recognition results of one kind of clip."""

    hits: list[bool] = field(default_factory=list)
    windows: list[float] = field(default_factory=list)
    frames: list[int] = field(default_factory=list)

    def add(self, recognizer: Recognizer, clip: Motion, style: str) -> None:
        self.frames.append(clip.frame_count)
        self.hits.append(recognizer.predict(clip) == style)
        self.windows.append(recognizer.window_accuracy(clip, style))

    def rate(self) -> str:
        return (
            f"{100 * np.mean(self.hits):5.1f} % ({100 * np.mean(self.windows):5.1f} % of windows, "
            f"{sum(self.hits)}/{len(self.hits)})"
        )


def adaptation_windows(take: Motion, budget: float, count: int) -> list[Motion]:
    """Disjoint ``budget``-second windows of the take, or the whole take if it is too short."""
    frames = round(budget / take.frame_time)
    if budget <= 0 or take.frame_count < 2 * frames:
        return [take]
    starts = range(0, take.frame_count - frames + 1, frames)
    return [take.slice(start, start + frames) for start in list(starts)[:count]]


@dataclass
class Condition:
    """Results for one amount of adaptation data."""

    budget: float
    trials: dict[tuple[str, str], list[Motion]]  # (style, fold) -> adaptation windows
    adapted: Tally = field(default_factory=Tally)
    scratch: Tally = field(default_factory=Tally)
    gv_on: list[float] = field(default_factory=list)
    gv_off: list[float] = field(default_factory=list)


def report(action: str, condition: Condition, original: Tally, chance: float, held_out: bool) -> None:
    trials = condition.trials
    whole = all(
        len(t) == 1 and t[0].frame_count == frames
        for t, frames in zip(trials.values(), original.frames, strict=True)
    )
    amount = (
        f"{condition.budget:g} s windows of the take"
        if not whole
        else "whole take"
        if condition.budget <= 0
        else f"whole take (shorter than two {condition.budget:g} s windows)"
    )
    amount += f", {sum(map(len, trials.values()))} trials"
    kind = (
        "held out: recognizer trained on the other take"
        if held_out
        else "NOT measurable held-out: one take per style, the recognizer saw it"
    )
    print(f"  -- adaptation data: {amount}; {kind}")
    print(f"     original takes        {original.rate()}")
    print(f"     synthesized, adapted  {condition.adapted.rate()}")
    print(f"     synthesized, scratch  {condition.scratch.rate()}")
    pairs = list(zip(condition.adapted.hits, condition.scratch.hits, strict=True))
    wins = sum(a and not b for a, b in pairs)
    losses = sum(b and not a for a, b in pairs)
    rate_a, rate_s = 100 * np.mean(condition.adapted.hits), 100 * np.mean(condition.scratch.hits)
    p_value = sign_test(wins, losses)
    if not held_out:
        verdict = "excluded (not held-out)"
    elif rate_a <= rate_s:
        verdict = "does NOT hold"
    elif p_value < 0.05:
        verdict = "HOLDS"
    else:
        verdict = f"holds numerically only (+{rate_a - rate_s:.1f} points, not significant)"
    print(
        f"  {action} [{amount}]: original {100 * np.mean(original.hits):.1f} % / adapted {rate_a:.1f} % / "
        f"scratch {rate_s:.1f} % / chance {chance:.1f} %; adaptation beats scratch: {verdict} "
        f"(paired: only adapted right {wins}, only scratch right {losses}, "
        f"sign test p = {p_value:.2f})"
    )
    print(
        f"     GV ratio synth/original (median over joints, mean over trials): "
        f"GV on {np.mean(condition.gv_on):.2f} (min {np.min(condition.gv_on):.2f}, "
        f"max {np.max(condition.gv_on):.2f}), GV off {np.mean(condition.gv_off):.2f}"
    )


def evaluate(
    library: MotionLibrary,
    action: str,
    shared_average: bool,
    budgets: list[float],
    count: int,
    cross: bool = True,
) -> None:
    clips = sorted(library.select(action=action), key=lambda c: c.id)
    styles = sorted({c.style for c in clips})
    takes = {s: [c for c in clips if c.style == s] for s in styles}
    first = {s: library.motion(takes[s][0]) for s in styles}
    second = {s: library.motion(takes[s][-1]) for s in styles}  # take 001 again if alone
    template = build_template([library.motion(c) for c in clips])
    held_out = all(len(takes[s]) > 1 for s in styles)
    # Folds: (take the data comes from, take the recognizer learns).  With two takes per
    # style both directions are run (2-fold cross-validation), else the single take plays
    # both roles (not held-out).
    folds = {"take 001": (first, second)}
    if held_out and cross:
        folds["take 002"] = (second, first)
    recognizers = {
        name: Recognizer(template, [(known[s], s) for s in styles])
        for name, (_, known) in folds.items()
    }
    chance = 100 / len(styles)
    conditions = [
        Condition(
            b,
            {
                (s, name): adaptation_windows(data[s], b, count)
                for s in styles
                for name, (data, _) in folds.items()
            },
        )
        for b in budgets
    ]
    print(
        f"\n== {action}: {len(styles)} styles, {len(clips)} clips; chance {chance:.1f} %; "
        f"average model: {'shared (saw the style: not a verdict!)' if shared_average else 'leave one style out'}; "
        f"adaptation data from {' and '.join(folds)}"
    )
    timings: dict[str, list[float]] = {"train": [], "adapt": [], "scratch": [], "synth_per_s": []}
    shared: HsmmModel | None = None
    if shared_average:
        started = time.perf_counter()
        shared = api.train_average([(first[s], s) for s in styles], action)
        timings["train"].append(time.perf_counter() - started)
    original = Tally()
    average = shared
    for style in styles:
        if shared is None:
            started = time.perf_counter()
            average = api.train_average([(first[s], s) for s in styles if s != style], action)
            timings["train"].append(time.perf_counter() - started)
        assert average is not None
        for name, (data_take, _) in folds.items():
            recognizer = recognizers[name]
            take: Motion = data_take[style]
            original.add(recognizer, take, style)
            real = joint_gv(take, template)
            moving = real > 1e-4  # joints that actually move (Bandai's joint_Root never does)
            seconds = take.duration
            for condition in conditions:
                for data in condition.trials[style, name]:
                    started = time.perf_counter()
                    adapted = api.adapt_model(average, [data], style)
                    timings["adapt"].append(time.perf_counter() - started)
                    started = time.perf_counter()
                    scratch = api.train_scratch([(data, style)], action)
                    timings["scratch"].append(time.perf_counter() - started)
                    started = time.perf_counter()
                    synth_on = api.synthesize(adapted, duration_s=seconds, seed=0)
                    timings["synth_per_s"].append((time.perf_counter() - started) / seconds)
                    synth_off = api.synthesize(adapted, duration_s=seconds, gv=False, seed=0)
                    condition.adapted.add(recognizer, synth_on, style)
                    scratch_clip = api.synthesize(scratch, duration_s=seconds, seed=0)
                    condition.scratch.add(recognizer, scratch_clip, style)
                    for bucket, clip in ((condition.gv_on, synth_on), (condition.gv_off, synth_off)):
                        bucket.append(float(np.median(joint_gv(clip, template)[moving] / real[moving])))
    for condition in conditions:
        report(action, condition, original, chance, held_out)
    print(
        f"  times: average training {np.mean(timings['train']):.2f} s, adaptation "
        f"{np.mean(timings['adapt']):.2f} s, scratch {np.mean(timings['scratch']):.2f} s, "
        f"synthesis {1000 * np.mean(timings['synth_per_s']):.1f} ms per second of motion"
    )
    best = []
    assert average is not None
    for _ in range(5):
        started = time.perf_counter()
        api.synthesize(average, duration_s=5.0)
        best.append(time.perf_counter() - started)
    print(f"  synthesis of 5 s: {1000 * min(best):.0f} ms (best of 5, GV on)")


def main() -> int:
    default = Path(os.environ.get("MSE_SHARED", Path(__file__).resolve().parents[2] / "shared"))
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--library", default=str(default / "motion" / "bandai-ds1"))
    parser.add_argument("--actions", nargs="+", default=["walk", "bow"])
    parser.add_argument("--shared-average", action="store_true")
    parser.add_argument(
        "--budget",
        type=float,
        nargs="+",
        default=[2.0, 1.0, 0.0],
        help="seconds of adaptation data; several: one report each (0: the whole take)",
    )
    parser.add_argument("--windows", type=int, default=3, help="adaptation windows per style")
    parser.add_argument(
        "--one-fold", action="store_true", help="adapt from take 001 only (no 2-fold swap)"
    )
    args = parser.parse_args()
    library = load_library(args.library)
    with api.single_threaded_blas():
        for action in args.actions:
            evaluate(
                library, action, args.shared_average, args.budget, args.windows, not args.one_fold
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

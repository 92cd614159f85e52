"""Evaluation of the HSMM stylistic synthesis (issue 7) on Bandai dataset 1 walks and bows.

    python -m bench.evaluation.style_eval [--library ../shared/motion/bandai-ds1] [--actions walk bow]
                               [--steps 1 2 4 0] [--runs 0] [--one-fold] [--split-take]
                               [--shared-average]

Question: does adapting the average model to a style from LITTLE data give clips whose style
is recognised better than a model trained from scratch on the SAME little data?  Reported
per action and amount of data: recognition of real clips, of clips synthesized by the
adapted model and by the scratch model, chance, and whether "adaptation beats scratch"
holds; then the over-smoothing ratio (GV on/off) and times.

Protocol (documented in docs/hsmm.md):

* Little data = a few steps.  The whole take is segmented into steps (units in context:
  first / inner / last, swing leg); the adaptation data of a style is a run of ``--steps``
  consecutive steps, LABELLED AS IN THE TAKE (a run from the middle of a walk holds inner
  steps only; the paper labels steps by hand the same way).  Every disjoint run of a take
  is a trial (``--runs`` caps them).  0, or a take with fewer than two runs' worth of
  steps, uses the whole take.  The scratch model is trained on exactly the same labelled
  frames with exactly the same code (``api.train_scratch``) minus the average-model prior.
  One-shot actions (bow) have one unit per take: whole takes only.
* Average model.  Trained on take 001 of the OTHER 14 styles (leave one style out), so it
  never saw the target style.  ``--shared-average`` trains one model over all 15 styles
  (faster, but it saw the style: a quick check only, never the verdict).
* Recognizer.  Trained on real clips only, never on a take that is evaluated: walks have two
  takes per style, so two folds are run (data from take 001, recognizer trained on take 002
  of every style; then the other way round; ``--one-fold`` keeps the first).  2 s windows
  (hop 0.5 s) of the aligned exponential-map features summarised by mean, standard
  deviation and mean absolute velocity per dimension, standardised, multinomial logistic
  regression; a clip gets the style with the best mean window log-probability.  Originals
  evaluated = the data takes; synthesized clips have the data take's length.  Other
  actions have ONE take per style: without ``--split-take`` the recognizer is trained on
  the takes it evaluates (rates marked "NOT measurable held-out", no verdict); with it,
  a cyclic action's two halves play the two takes (held out in time, same session).
* Chance = 1 / number of styles.  Verdict: adapted vs scratch per trial, with the paired
  count (trials only adaptation got right / only scratch got right) and a two-sided sign
  test, AND per (style, take) -- trials of one style are not independent -- with a sign
  test over the rate differences.  "HOLDS" needs a higher rate and p < 0.05 in both.  A
  graded score, the mean log-probability the recognizer gives the true style, is reported
  with the same two tests.
"""

from __future__ import annotations

import argparse
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mse.motion.base.bvh import Motion
from mse.motion.base.cycles import CycleKind, action_shape
from mse.motion.base.library import MotionLibrary, load_library
from mse.motion.hsmm import api
from mse.motion.hsmm.features import FloatArray
from mse.motion.hsmm.model import HsmmModel
from mse.motion.hsmm.prep import Template, build_template, static_features
from mse.motion.hsmm.segment import Segment

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

    def true_style_score(self, motion: Motion, style: str) -> float:
        """Mean window log-probability of the true style (graded recognition)."""
        rows = window_descriptors(static_features(motion, self.template))
        return float(self.model.predict_log_proba(rows)[:, self.classes.index(style)].mean())

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


def wilcoxon(differences: list[float] | FloatArray) -> float:
    """Two-sided Wilcoxon signed-rank p-value of paired differences (zeros dropped)."""
    from scipy.stats import wilcoxon as scipy_wilcoxon

    values = np.asarray(differences, dtype=np.float64)
    values = values[np.abs(values) > 1e-12]
    if values.size == 0:
        return 1.0
    return float(scipy_wilcoxon(values).pvalue)


@dataclass
class Tally:
    """Recognition results of one kind of clip."""

    hits: list[bool] = field(default_factory=list)
    windows: list[float] = field(default_factory=list)
    scores: list[float] = field(default_factory=list)
    frames: list[int] = field(default_factory=list)

    def add(self, recognizer: Recognizer, clip: Motion, style: str) -> None:
        self.frames.append(clip.frame_count)
        self.hits.append(recognizer.predict(clip) == style)
        self.windows.append(recognizer.window_accuracy(clip, style))
        self.scores.append(recognizer.true_style_score(clip, style))

    def rate(self) -> str:
        return (
            f"{100 * np.mean(self.hits):5.1f} % ({100 * np.mean(self.windows):5.1f} % of windows, "
            f"{sum(self.hits)}/{len(self.hits)})"
        )


@dataclass(frozen=True)
class Source:
    """The data of one style in one fold: labelled steps of a take, and that part as a clip."""

    take: Motion  # the whole take (features are computed on it, so edges keep their context)
    segments: list[Segment]  # the units of the part used, labelled as in the whole take
    clip: Motion  # that part of the take: the evaluated original, and the synthesis length


def source(take: Motion, template: Template, cyclic: CycleKind, start: int = 0, stop: int | None = None) -> Source:
    """The steps of ``take`` that lie inside frames ``[start, stop)``."""
    stop = take.frame_count if stop is None else stop
    inside = [s for s in api.segment_motion(take, template, cyclic) if s.start >= start and s.stop <= stop]
    return Source(take, inside, take.slice(start, stop))


def step_runs(segments: list[Segment], steps: int, count: int) -> list[list[Segment]]:
    """Disjoint runs of ``steps`` consecutive units, or all of them (``steps`` 0, or fewer
    than two runs' worth)."""
    if steps <= 0 or len(segments) < 2 * steps:
        return [segments]
    runs = [segments[i : i + steps] for i in range(0, len(segments) - steps + 1, steps)]
    return runs[: count or None]


@dataclass
class Condition:
    """Results for one amount of adaptation data."""

    steps: int
    trials: dict[tuple[str, str], list[list[Segment]]]  # (style, fold) -> runs of steps
    adapted: Tally = field(default_factory=Tally)
    scratch: Tally = field(default_factory=Tally)
    gv_on: list[float] = field(default_factory=list)
    gv_off: list[float] = field(default_factory=list)
    clusters: list[tuple[str, str]] = field(default_factory=list)  # (style, fold) of each trial


def cluster_differences(condition: Condition, what: str) -> FloatArray:
    """Per (style, fold): mean adapted minus mean scratch of ``hits`` or ``scores``."""
    adapted = np.asarray(getattr(condition.adapted, what), dtype=np.float64)
    scratch = np.asarray(getattr(condition.scratch, what), dtype=np.float64)
    keys = sorted(set(condition.clusters))
    index = np.array([keys.index(k) for k in condition.clusters])
    return np.array([adapted[index == i].mean() - scratch[index == i].mean() for i in range(len(keys))])


def report(action: str, condition: Condition, original: Tally, chance: float, held_out: bool) -> None:
    trials = condition.trials
    whole = all(len(runs) == 1 for runs in trials.values())
    amount = (
        "whole take"
        if condition.steps <= 0
        else f"runs of {condition.steps} steps"
        if not whole
        else f"whole take (fewer than {2 * condition.steps} steps)"
    )
    amount += f", {sum(map(len, trials.values()))} trials"
    halves = "half" in condition.clusters[0][1]
    kind = (
        f"held out: recognizer trained on the other {'half of the take' if halves else 'take'}"
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
    # Trials of one style share the style's difficulty, so they are not independent: the
    # same comparison with each (style, fold) as ONE unit (its rate difference) is the
    # conservative test.  The verdict needs both.
    by_cluster = cluster_differences(condition, "hits")
    c_wins, c_losses = int(np.sum(by_cluster > 0)), int(np.sum(by_cluster < 0))
    c_p = sign_test(c_wins, c_losses)
    score_a, score_s = np.mean(condition.adapted.scores), np.mean(condition.scratch.scores)
    score_p = wilcoxon(np.subtract(condition.adapted.scores, condition.scratch.scores))
    score_c = cluster_differences(condition, "scores")
    score_cp = sign_test(int(np.sum(score_c > 0)), int(np.sum(score_c < 0)))
    if not held_out:
        verdict = "excluded (not held-out)"
    elif rate_a <= rate_s:
        verdict = "does NOT hold"
    elif p_value < 0.05 and c_p < 0.05:
        verdict = "HOLDS"
    elif p_value < 0.05:
        verdict = f"holds per trial only (+{rate_a - rate_s:.1f} points; per style p = {c_p:.2f})"
    else:
        verdict = f"holds numerically only (+{rate_a - rate_s:.1f} points, not significant)"
    print(
        f"  {action} [{amount}]: original {100 * np.mean(original.hits):.1f} % / adapted {rate_a:.1f} % / "
        f"scratch {rate_s:.1f} % / chance {chance:.1f} %; adaptation beats scratch: {verdict} "
        f"(paired: only adapted right {wins}, only scratch right {losses}, "
        f"sign test p = {p_value:.3f}; per (style, take): adapted better {c_wins}, scratch better "
        f"{c_losses}, sign test p = {c_p:.3f})"
    )
    print(
        f"     graded: mean log P(true style) adapted {score_a:.2f} / scratch {score_s:.2f} / "
        f"original {np.mean(original.scores):.2f} (chance {math.log(chance / 100):.2f}); "
        f"Wilcoxon per trial p = {score_p:.3f}; per (style, take) adapted higher "
        f"{int(np.sum(score_c > 0))} of {len(score_c)}, sign test p = {score_cp:.3f}"
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
    budgets: list[int],
    count: int,
    cross: bool = True,
    split: bool = False,
) -> None:
    clips = sorted(library.select(action=action), key=lambda c: c.id)
    styles = sorted({c.style for c in clips})
    takes = {s: [c for c in clips if c.style == s] for s in styles}
    first = {s: library.motion(takes[s][0]) for s in styles}
    second = {s: library.motion(takes[s][-1]) for s in styles}  # take 001 again if alone
    template = build_template([library.motion(c) for c in clips])
    cyclic = action_shape([library.motion(c) for c in clips]).cycle
    held_out = all(len(takes[s]) > 1 for s in styles)
    # Folds: (where the data comes from, what the recognizer learns).  With two takes per
    # style both directions are run (2-fold cross-validation), else the single take plays
    # both roles (not held-out) or, with --split-take, its halves play two takes.
    data_one = {s: source(first[s], template, cyclic) for s in styles}
    data_two = {s: source(second[s], template, cyclic) for s in styles}
    names = ("take 001", "take 002")
    if not held_out and split and cyclic != "none":
        # Held out in time only: same performer and session, weaker than a second take.
        half = {s: first[s].frame_count // 2 for s in styles}
        data_one = {s: source(first[s], template, cyclic, 0, half[s]) for s in styles}
        data_two = {s: source(first[s], template, cyclic, half[s]) for s in styles}
        held_out, names = True, ("first half", "second half")
    folds = {names[0]: (data_one, data_two)}
    if held_out and cross:
        folds[names[1]] = (data_two, data_one)
    recognizers = {
        name: Recognizer(template, [(known[s].clip, s) for s in styles]) for name, (_, known) in folds.items()
    }
    chance = 100 / len(styles)
    conditions = [
        Condition(
            b,
            {(s, name): step_runs(data[s].segments, b, count) for s in styles for name, (data, _) in folds.items()},
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
    # The average model learns from whole takes 001 of the (other) styles.
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
        for name, (data_sources, _) in folds.items():
            recognizer = recognizers[name]
            data = data_sources[style]
            original.add(recognizer, data.clip, style)
            real = joint_gv(data.clip, template)
            moving = real > 1e-4  # joints that actually move (Bandai's joint_Root never does)
            seconds = data.clip.duration
            for condition in conditions:
                for run in condition.trials[style, name]:
                    started = time.perf_counter()
                    adapted = api.adapt_model(average, [data.take], style, segmentation=[run])
                    timings["adapt"].append(time.perf_counter() - started)
                    started = time.perf_counter()
                    scratch = api.train_scratch([(data.take, style)], action, segmentation=[run])
                    timings["scratch"].append(time.perf_counter() - started)
                    started = time.perf_counter()
                    synth_on = api.synthesize(adapted, duration_s=seconds, seed=0)
                    timings["synth_per_s"].append((time.perf_counter() - started) / seconds)
                    synth_off = api.synthesize(adapted, duration_s=seconds, gv=False, seed=0)
                    condition.clusters.append((style, name))
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
    default = Path(os.environ.get("MSE_SHARED", Path(__file__).resolve().parents[3] / "shared"))
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--library", default=str(default / "motion" / "bandai-ds1"))
    parser.add_argument("--actions", nargs="+", default=["walk", "bow"])
    parser.add_argument("--shared-average", action="store_true")
    parser.add_argument(
        "--steps",
        type=int,
        nargs="+",
        default=[1, 2, 4, 0],
        help="adaptation data in steps (units) of a take; several: one report each (0: the whole take)",
    )
    parser.add_argument(
        "--runs", type=int, default=0, help="runs of steps per style and take (0: every disjoint one)"
    )
    parser.add_argument(
        "--split-take",
        action="store_true",
        help="cyclic actions with one take per style: its halves play two takes (held out in time)",
    )
    parser.add_argument(
        "--one-fold", action="store_true", help="adapt from take 001 only (no 2-fold swap)"
    )
    args = parser.parse_args()
    library = load_library(args.library)
    with api.single_threaded_blas():
        for action in args.actions:
            evaluate(
                library, action, args.shared_average, args.steps, args.runs, not args.one_fold, args.split_take
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

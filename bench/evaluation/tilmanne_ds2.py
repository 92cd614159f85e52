"""Tilmanne et al.'s claim on Bandai dataset 2 walks: does adapting an average model beat a
model trained from scratch on the same few takes?

    python -m bench.evaluation.tilmanne_ds2 [--data ../shared/motion/bandai-ds2] [--takes 1,2,4,8]
                                 [--trials 3] [--held-out 5] [--average-takes 4]

Protocol, per target style (7 styles):

- **held out**: ``--held-out`` takes of the style (chosen with a fixed seed) are never used
  for training, adaptation or the recognizer's training;
- **average model**: trained (style-adaptive training) on ``--average-takes`` takes of each
  of the *other* six styles: it never saw the target style;
- for n in ``--takes``, ``--trials`` random sets of n adaptation takes from the style's
  remaining takes; on each set, the average model **adapted** (CMLLR + MAP, the default
  options) and a model trained **from scratch** (same code, same states and iterations, same
  skeleton template and features as the average model, no prior);
- measures on the held-out takes of the style:
  1. **held-out likelihood**: the mean log-likelihood per frame of each held-out take under
     each model (the take's steps, forced through the model's units by the HSMM Viterbi
     search: output and duration densities). The model that predicts unseen walks of the
     style better is the better model of the style;
  2. **recognition**: a clip synthesized by each model, as long as the held-out take, is
     rated by a style recognizer trained on real takes of all styles minus the held-out ones
     (2 s windows of the aligned features, as ``bench/evaluation/style_eval.py``);
- tests, per n: (a) paired over trials x held-out takes within each style, adapted vs
  scratch likelihood, Wilcoxon signed-rank; (b) over the 7 styles, the sign of the mean
  difference, two-sided sign test. "Adaptation beats scratch" **holds** at n when the mean
  difference is positive and p < 0.05 in the test over styles (the unit that is not
  repeated); recognition is reported beside it with a sign test over trials.
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

from bench.evaluation.style_eval import Recognizer, sign_test, wilcoxon
from mse.motion.base.bvh import Motion
from mse.motion.base.library import load_library
from mse.motion.hsmm import api
from mse.motion.hsmm.model import HsmmModel, align, frame_loglik
from mse.motion.hsmm.synth import synthesize


def heldout_loglik(model: HsmmModel, motion: Motion) -> float:
    """Mean log-likelihood per frame of a take under ``model`` (its steps forced through
    the model's units, best state split of each step)."""
    instances, _ = api.clip_instances(
        motion, model.style, model.template, model.cycle, model.states
    )
    total, frames = 0.0, 0
    for instance in instances:
        unit = model.unit(instance.unit)
        loglik = frame_loglik(instance.observations, unit.means, unit.variances)
        _, score = align(loglik, unit)
        if np.isfinite(score):
            total += score
            frames += instance.observations.shape[0]
    return total / max(frames, 1)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    shared = Path(os.environ.get("MSE_SHARED", Path(__file__).resolve().parents[3] / "shared"))
    parser.add_argument("--data", default=str(shared / "motion" / "bandai-ds2"))
    parser.add_argument("--action", default="walk")
    parser.add_argument("--takes", default="1,2,4,8")
    parser.add_argument("--trials", type=int, default=3)
    parser.add_argument("--held-out", type=int, default=5)
    parser.add_argument("--average-takes", type=int, default=4)
    parser.add_argument("--styles", help="comma-separated (default: all)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    library = load_library(args.data)
    rng = np.random.default_rng(args.seed)
    clips = sorted(library.select(args.action), key=lambda c: c.id)
    styles = sorted({c.style for c in clips})
    chosen = args.styles.split(",") if args.styles else styles
    by_style = {s: [c for c in clips if c.style == s] for s in styles}
    held: dict[str, list[int]] = {}
    for style in styles:
        order = rng.permutation(len(by_style[style]))
        held[style] = sorted(int(i) for i in order[: args.held_out])
    amounts = [int(x) for x in args.takes.split(",")]
    # results[n][style] = list of (adapted - scratch) likelihood differences, and recognition
    differences: dict[int, dict[str, list[float]]] = defaultdict(lambda: defaultdict(list))
    recognised: dict[int, dict[str, list[tuple[bool, bool]]]] = defaultdict(lambda: defaultdict(list))
    likelihoods: dict[int, dict[str, list[tuple[float, float]]]] = defaultdict(lambda: defaultdict(list))
    started = time.perf_counter()
    for style in chosen:
        pool = [c for i, c in enumerate(by_style[style]) if i not in held[style]]
        tests = [library.motion(by_style[style][i]) for i in held[style]]
        others = []
        for other in styles:
            if other == style:
                continue
            kept = [c for i, c in enumerate(by_style[other]) if i not in held[other]]
            others += [(library.motion(c), other) for c in kept[: args.average_takes]]
        clock = time.perf_counter()
        average = api.train_average(others, args.action)
        trained = time.perf_counter() - clock
        real = []
        for other in styles:
            kept = [c for i, c in enumerate(by_style[other]) if i not in held[other]]
            real += [(library.motion(c), other) for c in kept[:6]]
        recognizer = Recognizer(average.template, real)
        for n in amounts:
            if n > len(pool):
                continue
            for _ in range(args.trials):
                picks = rng.choice(len(pool), size=n, replace=False)
                data = [library.motion(pool[int(i)]) for i in picks]
                adapted = api.adapt_model(average, data, style)
                scratch = api.train_scratch([(m, style) for m in data], args.action, template=average.template)
                for test in tests:
                    a, s = heldout_loglik(adapted, test), heldout_loglik(scratch, test)
                    differences[n][style].append(a - s)
                    likelihoods[n][style].append((a, s))
                    duration = test.duration
                    hit_a = recognizer.predict(synthesize(adapted, duration_s=duration, seed=0)) == style
                    hit_s = recognizer.predict(synthesize(scratch, duration_s=duration, seed=0)) == style
                    recognised[n][style].append((hit_a, hit_s))
        print(
            f"{style}: average model {trained:.1f} s; {time.perf_counter() - started:.0f} s so far",
            file=sys.stderr,
            flush=True,
        )
    report(amounts, chosen, differences, likelihoods, recognised)
    return 0


def report(
    amounts: list[int],
    styles: list[str],
    differences: dict[int, dict[str, list[float]]],
    likelihoods: dict[int, dict[str, list[tuple[float, float]]]],
    recognised: dict[int, dict[str, list[tuple[bool, bool]]]],
) -> None:
    print("held-out log-likelihood per frame (adapted / scratch), per style; recognition of synthesized walks")
    for n in amounts:
        if n not in differences:
            continue
        print(f"\n== {n} take(s) of the target style")
        style_means = []
        for style in styles:
            pairs = likelihoods[n][style]
            if not pairs:
                continue
            a = np.mean([p[0] for p in pairs])
            s = np.mean([p[1] for p in pairs])
            diff = differences[n][style]
            p = wilcoxon(diff)
            hits = recognised[n][style]
            rec_a = np.mean([h[0] for h in hits])
            rec_s = np.mean([h[1] for h in hits])
            style_means.append(float(np.mean(diff)))
            print(
                f"  {style:<10} adapted {a:8.1f}  scratch {s:8.1f}  diff {np.mean(diff):+7.1f}  "
                f"(Wilcoxon p = {p:.3g}, n = {len(diff)})   recognised {100 * rec_a:5.1f} % / {100 * rec_s:5.1f} %"
            )
        wins = sum(1 for d in style_means if d > 0)
        losses = sum(1 for d in style_means if d < 0)
        p_styles = sign_test(wins, losses)
        all_hits = [h for style in styles for h in recognised[n][style]]
        only_a = sum(1 for h in all_hits if h[0] and not h[1])
        only_s = sum(1 for h in all_hits if h[1] and not h[0])
        rec_a = 100 * np.mean([h[0] for h in all_hits])
        rec_s = 100 * np.mean([h[1] for h in all_hits])
        verdict = "HOLDS" if np.mean(style_means) > 0 and p_styles < 0.05 else (
            "REFUTED" if np.mean(style_means) < 0 and p_styles < 0.05 else "not established")
        print(
            f"  styles where adaptation predicts held-out walks better: {wins}/{wins + losses} "
            f"(sign test p = {p_styles:.3g}) -> {verdict}"
        )
        print(
            f"  recognition: adapted {rec_a:.1f} %, scratch {rec_s:.1f} % "
            f"(only adapted {only_a}, only scratch {only_s}, sign test p = {sign_test(only_a, only_s):.3g})"
        )


if __name__ == "__main__":
    raise SystemExit(main())

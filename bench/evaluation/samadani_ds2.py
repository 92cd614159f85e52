"""Samadani et al.'s objective validation on Bandai dataset 2 (many takes per style).

    python -m bench.evaluation.samadani_ds2 [--data ../shared/motion/bandai-ds2] [--per-group 1] [--folds 10]

Protocol (the paper's §IV with data that allows it):

- the clips are split into 10 folds, stratified by (action, style);
- in each fold, ``--per-group`` desired paths per (action, style) are taken from the fold and
  generated in every *other* style of their action by the LMA + HMM method, from a library
  without the fold (RMLR, neighbours and HMM see training folds only);
- a style recognizer per action (:class:`bench.evaluation.recognize.StyleRecognizer`, C = 1)
  is trained on the training folds' real clips of that action only and rates: the fold's real clips (**real** rate), the
  generated clips (**generated**: recognised as the target style), and two baselines on the
  same conversions: **identity** (the desired path itself, unchanged) and **time-warped copy**
  (the nearest target-style neighbour the method chose, resampled to the desired path's
  length);
- ratio = generated / real (the paper: 72 % / 72 %); 95 % intervals: Wilson for rates, a
  bootstrap over desired paths for the ratio;
- fidelity (:mod:`bench.evaluation.fidelity`) of every generated clip against the training
  folds' real clips of its action and target style.

``--warp-augment 0.75,1.33`` (default) also trains the recognizer on every training clip
time-warped by those factors, so that it rates a style by its movement rather than by the
clip's tempo (durations are imposed by the timeline in ``mse animate``; without it a
time-warped copy of a real target-style clip is rated like a generated one).
Descriptors of real clips are cached under ``$MSE_CACHE_DIR/bench``.

``--length distance`` (default; deviation from the paper, whose generated clip has the desired
path's length): a clip of a travelling action (walk: forward speed is its signature in
:mod:`bench.evaluation.fidelity`) is generated for as long as the chosen neighbours take to
cover the desired path's travel. Bandai's walk takes all cross the same room (elderly ones
in 13-15 s, active ones in 7 s); an elderly walk generated at an active desired path's 7 s
covers half of it, and the recognizer, trained on whole takes, rated it normal (fold 1:
1 of 6 elderly walks recognised). ``--length desired`` is the paper's.

``--show-failures`` prints every conversion that fails a fidelity check (clip, target,
values and admitted ranges) on stderr, and ``--only-conversions FOLD:CLIP:TARGET,...`` redoes
exactly those (folds and desired paths are drawn over every clip whatever the filters, so
``--actions``, ``--only-folds`` and ``--only-conversions`` redo a full run's conversions).
Note that ``--actions`` changes the folds (they are drawn over the clips kept).
"""

from __future__ import annotations

import argparse
import hashlib
import os
import sys
import time
import warnings
from collections import defaultdict
from pathlib import Path

import numpy as np

from bench.evaluation.fidelity import ACTION_SIGNATURES, check, measure, reference
from bench.evaluation.recognize import StyleRecognizer, style_descriptor
from mse.motion.base.bvh import Motion
from mse.motion.base.compose import resample_motion
from mse.motion.base.library import Clip, MotionLibrary, load_library
from mse.motion.lma_hmm.generate import GenerationParams, generate_motion


def wilson(successes: int, total: int, z: float = 1.96) -> tuple[float, float]:
    if total == 0:
        return 0.0, 0.0
    p = successes / total
    centre = (p + z * z / (2 * total)) / (1 + z * z / total)
    half = z * np.sqrt(p * (1 - p) / total + z * z / (4 * total * total)) / (1 + z * z / total)
    return centre - half, centre + half


def folds_of(clips: list[Clip], count: int, seed: int) -> dict[str, int]:
    """clip id -> fold, stratified by (action, style)."""
    rng = np.random.default_rng(seed)
    groups: dict[tuple[str, str], list[Clip]] = defaultdict(list)
    for clip in clips:
        groups[clip.action, clip.style].append(clip)
    fold: dict[str, int] = {}
    for key in sorted(groups):
        members = sorted(groups[key], key=lambda c: c.id)
        order = rng.permutation(len(members))
        offset = int(rng.integers(count))
        for rank, index in enumerate(order):
            fold[members[index].id] = (rank + offset) % count
    return fold


def warped(motion: Motion, factor: float) -> Motion:
    """The clip played ``factor`` times slower."""
    return resample_motion(motion, motion.duration * factor)


def travels(action: str) -> bool:
    """Whether the action's signature is a travel speed (walks, runs)."""
    return any(m in ("forward_speed", "side_speed") for m in ACTION_SIGNATURES.get(action, ()))


def _speed(library: MotionLibrary, clip: Clip, speeds: dict[str, float]) -> float:
    if clip.id not in speeds:
        values = measure(library.motion(clip))
        speeds[clip.id] = float(np.hypot(values["forward_speed"], values["side_speed"]))
    return speeds[clip.id]


def travel_time(library: MotionLibrary, desired: Clip, neighbours: tuple[str, ...], speeds: dict[str, float]) -> float:
    """Seconds the neighbours (median speed) take to cover the desired path's travel."""
    distance = _speed(library, desired, speeds) * library.motion(desired).duration
    pace = float(np.median([_speed(library, library.clip(n), speeds) for n in neighbours]))  # type: ignore[arg-type]
    return max(distance / max(pace, 1e-9), library.motion(desired).frame_time * 2)


class Descriptors:
    """Style descriptors of real clips (and their time-warped copies), cached on disk."""

    def __init__(self, library: MotionLibrary, folder: Path) -> None:
        self.library = library
        self.path = folder / f"descriptors-{library.content_hash}.npz"
        self.table: dict[str, np.ndarray] = {}
        if self.path.is_file():
            with np.load(self.path, allow_pickle=False) as archive:
                self.table = {key: archive[key] for key in archive.files}
        self.dirty = False

    def get(self, clip: Clip, factor: float = 1.0) -> np.ndarray:
        key = f"{clip.id}@{factor:g}"
        if key not in self.table:
            motion = self.library.motion(clip)
            self.table[key] = style_descriptor(motion if factor == 1.0 else warped(motion, factor))
            self.dirty = True
        return self.table[key]

    def save(self) -> None:
        if self.dirty:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            np.savez(self.path, **self.table)
            self.dirty = False


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    shared = Path(os.environ.get("MSE_SHARED", Path(__file__).resolve().parents[3] / "shared"))
    parser.add_argument("--data", default=str(shared / "motion" / "bandai-ds2"))
    parser.add_argument("--folds", type=int, default=10)
    parser.add_argument("--per-group", type=int, default=1, help="desired paths per (action, style) per fold")
    parser.add_argument("--warp-augment", default="0.75,1.33", help="time-warp factors added to training ('' none)")
    parser.add_argument("--regenerate", default="means", choices=("means", "frames"))
    parser.add_argument("--states", type=int, default=12)
    parser.add_argument("--timing", default="neighbours", choices=("neighbours", "desired"),
                        help="state runs timed as the neighbours' (default) or as the desired path's (the paper's)")
    parser.add_argument("--actions", help="comma-separated (development)")
    parser.add_argument("--max-neighbours", type=int, default=8)
    parser.add_argument("--min-neighbours", type=int, default=8)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--length", default="distance", choices=("distance", "desired"),
                        help="generated length of travelling actions: the neighbours' time to cover the desired "
                        "path's travel (default) or the desired path's own (the paper's)")
    parser.add_argument("--only-folds", help="comma-separated fold numbers (development)")
    parser.add_argument("--only-conversions",
                        help="FOLD:DESIRED_CLIP:TARGET_STYLE[,...] as --show-failures prints them (development)")
    parser.add_argument("--stride", default=GenerationParams().stride,
                        help="travelling bodies' swing widened: legs, all, off (docs/motion.md, step 12)")
    parser.add_argument("--show-failures", action="store_true",
                        help="print every conversion that fails a fidelity check, with the values")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    cache = Path(os.environ.get("MSE_CACHE_DIR", ".cache-mse"))
    library = load_library(args.data)
    clips = sorted(library.clips, key=lambda c: c.id)
    # Folds and desired paths are drawn over every clip, whatever the filters below, so that
    # --actions, --only-folds and --only-conversions redo exactly the conversions of a full run.
    fold = folds_of(clips, args.folds, args.seed)
    wanted_actions = set(args.actions.split(",")) if args.actions else None
    wanted_conversions = (
        {tuple(item.split(":")) for item in args.only_conversions.split(",")} if args.only_conversions else None
    )
    if wanted_conversions is not None and any(len(item) != 3 for item in wanted_conversions):
        parser.error("--only-conversions takes FOLD:DESIRED_CLIP:TARGET_STYLE[,...]")
    factors = [float(x) for x in args.warp_augment.split(",") if x.strip()]
    descriptors = Descriptors(library, cache / "bench")
    try:
        params = GenerationParams(
            regenerate=args.regenerate,
            timing=args.timing,
            states=args.states,
            min_neighbours=args.min_neighbours,
            max_neighbours=args.max_neighbours,
            stride=args.stride,
        )
    except ValueError as error:
        parser.error(str(error))
    rng = np.random.default_rng(args.seed)
    speeds: dict[str, float] = {}
    folds = {int(x) for x in args.only_folds.split(",")} if args.only_folds else set(range(args.folds))
    if wanted_conversions is not None:
        folds &= {int(item[0]) for item in wanted_conversions}
    real_hits: list[bool] = []
    rows: list[dict[str, object]] = []  # one per conversion
    started = time.perf_counter()
    timings: list[float] = []
    for f in range(args.folds):
        everything = [c for c in clips if fold[c.id] == f]
        excluded = [c.id for c in everything]
        groups: dict[tuple[str, str], list[Clip]] = defaultdict(list)
        for clip in everything:
            groups[clip.action, clip.style].append(clip)
        picks = {
            key: rng.choice(len(members), size=min(args.per_group, len(members)), replace=False)
            for key, members in sorted(groups.items())
        }
        if f not in folds:
            continue
        test = [c for c in everything if wanted_actions is None or c.action in wanted_actions]
        train = [c for c in clips if fold[c.id] != f and (wanted_actions is None or c.action in wanted_actions)]
        recognizers = {}
        for action in sorted({c.action for c in train}):
            mine = [c for c in train if c.action == action]
            table = [descriptors.get(c, factor) for factor in [1.0, *factors] for c in mine]
            labels = [c.style for _ in [1.0, *factors] for c in mine]
            recognizers[action] = StyleRecognizer.fit(np.array(table), [action] * len(labels), labels, c=1.0)
        descriptors.save()
        for clip in test:
            real_hits.append(recognizers[clip.action].predict(descriptors.get(clip), clip.action) == clip.style)
        references = {}
        for action in sorted({c.action for c in test}):
            own = [c for c in train if c.action == action]
            step = max(1, len(own) // 80)
            references[action] = reference(action, [library.motion(c) for c in own[::step]])
        for (action, original), members in sorted(groups.items()):
            if wanted_actions is not None and action not in wanted_actions:
                continue
            targets = sorted({c.style for c in train if c.action == action} - {original})
            for index in picks[action, original]:
                desired = members[int(index)]
                desired_motion = library.motion(desired)
                recognizer = recognizers[action]
                identity = recognizer.predict(descriptors.get(desired), action)
                for target in targets:
                    if wanted_conversions is not None and (str(f), desired.id, target) not in wanted_conversions:
                        continue
                    clock = time.perf_counter()
                    result = generate_motion(
                        library, action, target, clip=desired.id, exclude=excluded, params=params
                    )
                    if args.length == "distance" and travels(action):
                        duration = travel_time(library, desired, result.neighbours, speeds)
                        result = generate_motion(
                            library, action, target, clip=desired.id, exclude=excluded, params=params,
                            duration=duration,
                        )
                    timings.append(time.perf_counter() - clock)
                    generated = result.motion
                    label = recognizer.predict(style_descriptor(generated), action)
                    neighbour = library.motion(library.clip(result.neighbours[0]))  # type: ignore[arg-type]
                    copy = resample_motion(neighbour, desired_motion.duration)
                    copy_label = recognizer.predict(style_descriptor(copy), action)
                    own = [library.motion(c) for c in train if c.action == action and c.style == target]
                    style_reference = reference(action, own[:: max(1, len(own) // 20)])
                    checks = check(measure(generated), references[action], style_reference)
                    if args.show_failures and not all(c.passed for c in checks):
                        print(
                            f"fold {f} {desired.id} -> {target}: "
                            + ", ".join(f"{c.name} {c.value:.2f} [{c.low:.2f}, {c.high:.2f}]"
                                        for c in checks if not c.passed),
                            file=sys.stderr,
                            flush=True,
                        )
                    rows.append(
                        {
                            "fold": f,
                            "desired": desired.id,
                            "action": action,
                            "original": original,
                            "target": target,
                            "generated": label == target,
                            "label": label,
                            "identity": identity == target,
                            "copy": copy_label == target,
                            "fidelity": all(c.passed for c in checks),
                            "failed": [c.name for c in checks if not c.passed],
                            "neighbours": len(result.neighbours),
                            "cyclic": result.cyclic,
                        }
                    )
        mine = [r for r in rows if r["fold"] == f]
        by_target = {t: sum(bool(r["generated"]) for r in mine if r["target"] == t) for t in sorted(
            {str(r["target"]) for r in mine})}
        print(
            f"fold {f}: {len(test)} real clips, {len(mine)} conversions, "
            f"generated {sum(bool(r['generated']) for r in mine)}, fidelity {sum(bool(r['fidelity']) for r in mine)}, "
            f"per target {by_target}, {time.perf_counter() - started:.0f} s so far",
            file=sys.stderr,
            flush=True,
        )
    descriptors.save()
    report(real_hits, rows, timings, rng)
    return 0


def _line(name: str, hits: list[bool]) -> str:
    low, high = wilson(sum(hits), len(hits))
    return f"{name:<26} {100 * np.mean(hits):5.1f} %  [{100 * low:4.1f}, {100 * high:4.1f}]  (n = {len(hits)})"


def report(real: list[bool], rows: list[dict[str, object]], timings: list[float], rng: np.random.Generator) -> None:
    print(_line("real clips", real))
    names = {"generated": "generated (LMA + HMM)", "identity": "identity baseline", "copy": "time-warped copy"}
    for key, name in names.items():
        print(_line(name, [bool(r[key]) for r in rows]))
    generated = np.array([bool(r["generated"]) for r in rows], dtype=float)
    ratio = float(generated.mean() / max(np.mean(real), 1e-9))
    desired = sorted({str(r["desired"]) for r in rows})
    by_desired = {d: [float(bool(r["generated"])) for r in rows if r["desired"] == d] for d in desired}
    real_array = np.array(real, dtype=float)
    samples = []
    for _ in range(2000):
        pick = rng.choice(len(desired), size=len(desired))
        gen = np.mean([x for i in pick for x in by_desired[desired[i]]])
        re = np.mean(real_array[rng.integers(0, len(real_array), len(real_array))])
        samples.append(gen / max(re, 1e-9))
    low, high = np.percentile(samples, [2.5, 97.5])
    print(f"{'ratio generated / real':<26} {ratio:5.3f}    [{low:.3f}, {high:.3f}]  (target >= 0.9)")
    print(_line("fidelity passes", [bool(r["fidelity"]) for r in rows]))
    failures: dict[str, int] = defaultdict(int)
    for r in rows:
        for name in r["failed"]:  # type: ignore[attr-defined]
            failures[f"{r['action']}:{name}"] += 1
    if failures:
        print("fidelity failures: " + ", ".join(f"{k} {v}" for k, v in sorted(failures.items())))
    print("\nper action (generated / identity / copy / fidelity):")
    for action in sorted({str(r["action"]) for r in rows}):
        mine = [r for r in rows if r["action"] == action]
        values = [100 * np.mean([bool(r[k]) for r in mine]) for k in ("generated", "identity", "copy", "fidelity")]
        cyclic = np.mean([bool(r["cyclic"]) for r in mine])
        print(f"  {action:<22} " + " / ".join(f"{v:5.1f} %" for v in values) + f"  (cyclic HMMs {100 * cyclic:.0f} %)")
    print("\nper target style (generated):")
    for target in sorted({str(r["target"]) for r in rows}):
        mine = [bool(r["generated"]) for r in rows if r["target"] == target]
        print(f"  {target:<14} {100 * np.mean(mine):5.1f} %  (n = {len(mine)})")
    print("\nconfusion of the generated clips (rows: target, columns: recognised):")
    styles = sorted({str(r["target"]) for r in rows})
    for action in sorted({str(r["action"]) for r in rows}):
        print(f"  {action}: " + " ".join(f"{s[:6]:>6}" for s in styles))
        for target in styles:
            mine = [str(r["label"]) for r in rows if r["action"] == action and r["target"] == target]
            print(f"  {target:>{len(action) + 1}} " + " ".join(f"{mine.count(s):>6}" for s in styles))
    if timings:
        median, high = np.median(timings), np.percentile(timings, 90)
        print(f"\nper conversion: median {median:.2f} s, 90th percentile {high:.2f} s")
    neighbours = [int(r["neighbours"]) for r in rows]  # type: ignore[call-overload]
    low_n, high_n = min(neighbours), max(neighbours)
    print(f"neighbours per conversion: median {np.median(neighbours):.0f}, min {low_n}, max {high_n}")
    digest = hashlib.sha256(repr(sorted((str(r["desired"]), str(r["target"])) for r in rows)).encode()).hexdigest()[:8]
    print(f"conversions: {len(rows)} (set {digest})")


if __name__ == "__main__":
    raise SystemExit(main())

"""LMA feature tables, RMLR saliency and the ε-neighbourhood search (paper §III-B, §III-D).

- Features are the 27 components of :data:`mse.motion.base.lma.FEATURE_NAMES`, ``log1p``-compressed
  (Weight and Flow span orders of magnitude) and z-scored over the training clips.
- RMLR: scikit-learn multinomial ``LogisticRegression`` with an elastic-net penalty (saga);
  α (``l1_ratio``) and λ (``1/C``) chosen by a small stratified cross-validation
  (α ∈ {0.5, 1}, C ∈ {0.1, 0.5, 2, 8}, up to 3 folds; ties keep the stronger penalty) — the
  paper's 20 x 100 grid is too slow for an interactive tool. A component is salient to a class when its coefficient
  is non-zero.
- Eq. 12: the search space for original e1 -> target e2 is ``L \\ (L1 ∩ L2)``; with no known
  original emotion, ``L \\ L2``. At least :data:`MIN_SEARCH_DIMENSIONS` components are kept
  (the least salient ones are added back) so that the distance stays meaningful.
- Neighbours: target-style clips whose distance to the desired path is within ε = 10 % of
  the distance to the farthest target-style clip; at least the nearest one (the generator
  asks for the nearest eight when the library has them).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mse.extras import require
from mse.motion.base import cache
from mse.motion.base.kinematics import FloatArray
from mse.motion.base.library import Clip, MotionLibrary
from mse.motion.base.lma import FEATURE_NAMES, lma_features

MIN_SEARCH_DIMENSIONS = 3
L1_RATIOS = (0.5, 1.0)
C_GRID = (0.1, 0.5, 2.0, 8.0)
EPSILON_FRACTION = 0.1


def clip_features(library: MotionLibrary, clip: Clip) -> FloatArray:
    """The raw LMA vector of a clip (cached per library fingerprint and clip id)."""
    return cache.remembered(
        ("lma", library.content_hash, clip.id), lambda: lma_features(library.motion(clip), path=clip.source).vector()
    )


def feature_table(library: MotionLibrary, clips: Sequence[Clip]) -> FloatArray:
    return np.array([clip_features(library, c) for c in clips], dtype=np.float64)


@dataclass(frozen=True, eq=False)
class Saliency:
    """RMLR result: classes, per-class salient component masks, and the scaling used."""

    classes: tuple[str, ...]
    salient: FloatArray  # (classes, components) booleans as 0/1
    coefficients: FloatArray  # (classes, components)
    mean: FloatArray
    scale: FloatArray
    l1_ratio: float
    c: float

    def transform(self, raw: FloatArray) -> FloatArray:
        return (np.log1p(np.maximum(raw, 0.0)) - self.mean) / self.scale

    def search_components(self, target: str, original: str | None = None) -> list[int]:
        """Eq. 12: indices of the affectively non-discriminative components."""
        count = len(FEATURE_NAMES)
        if target not in self.classes:
            return list(range(count))
        t = self.classes.index(target)
        excluded = self.salient[t] > 0
        weight = np.abs(self.coefficients[t])
        if original is not None and original in self.classes and original != target:
            o = self.classes.index(original)
            excluded = excluded & (self.salient[o] > 0)
            weight = weight + np.abs(self.coefficients[o])
        kept = [i for i in range(count) if not excluded[i]]
        if len(kept) < MIN_SEARCH_DIMENSIONS:
            for i in np.argsort(weight, kind="stable"):
                if int(i) not in kept:
                    kept.append(int(i))
                if len(kept) >= MIN_SEARCH_DIMENSIONS:
                    break
        return sorted(kept)


def fit_rmlr(raw: FloatArray, labels: Sequence[str], *, seed: int = 0) -> Saliency:
    """Elastic-net multinomial logistic regression with a cheap (α, λ) cross-validation."""
    with require("motion"):
        import sklearn
        from sklearn.linear_model import LogisticRegression
        from sklearn.model_selection import StratifiedKFold, cross_val_score

    count = len(FEATURE_NAMES)
    raw = np.asarray(raw, dtype=np.float64).reshape(-1, count)
    if len(raw) == 0:  # nothing to learn from: every component is searched
        none = np.zeros((0, count))
        return Saliency((), none, none, np.zeros(count), np.ones(count), 1.0, 1.0)
    compressed = np.log1p(np.maximum(raw, 0.0))
    mean = compressed.mean(axis=0)
    scale = compressed.std(axis=0)
    scale[scale < 1e-12] = 1.0
    z = (compressed - mean) / scale
    classes, counts = np.unique(np.asarray(labels), return_counts=True)
    if len(classes) < 2:
        ones = np.ones((len(classes), count))
        return Saliency(tuple(map(str, classes)), ones, ones, mean, scale, 1.0, 1.0)
    old_api = tuple(int(p) for p in sklearn.__version__.split(".")[:2]) < (1, 8)

    def model(l1_ratio: float, c: float) -> LogisticRegression:
        options: dict[str, object] = {"penalty": "elasticnet"} if old_api else {}
        return LogisticRegression(
            C=c,
            l1_ratio=l1_ratio,
            solver="saga",
            max_iter=400,
            tol=1e-3,
            random_state=seed,
            **options,
        )

    folds = int(min(3, counts.min()))
    best = (0.5, 1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if folds >= 2:
            splitter = StratifiedKFold(folds, shuffle=True, random_state=seed)
            best_score = -1.0
            for l1_ratio in L1_RATIOS:
                for c in C_GRID:
                    score = float(cross_val_score(model(l1_ratio, float(c)), z, labels, cv=splitter).mean())
                    if score > best_score + 1e-9:
                        best_score, best = score, (l1_ratio, float(c))
        fitted = model(*best).fit(z, labels)
    coefficients = np.asarray(fitted.coef_, dtype=np.float64)
    if coefficients.shape[0] == 1:  # binary problems give one row: class 1 vs class 0
        coefficients = np.vstack([-coefficients[0], coefficients[0]])
    salient = (np.abs(coefficients) > 1e-8).astype(np.float64)
    names = tuple(str(c) for c in fitted.classes_)
    return Saliency(names, salient, coefficients, mean, scale, best[0], best[1])


def saliency_for(library: MotionLibrary, clips: Sequence[Clip]) -> Saliency:
    """RMLR over ``clips`` (cached per library fingerprint and clip set)."""
    return cache.remembered(
        ("rmlr", library.content_hash, tuple(c.id for c in clips)),
        lambda: fit_rmlr(feature_table(library, clips), [c.style for c in clips]),
    )


def nearest_neighbours(
    desired: FloatArray,
    candidates: FloatArray,
    components: Sequence[int],
    saliency: Saliency,
    epsilon_fraction: float = EPSILON_FRACTION,
    *,
    minimum: int = 1,
    maximum: int | None = None,
) -> list[int]:
    """Indices (into ``candidates``) within ε of ``desired``, nearest first; at least the
    nearest ``minimum`` (when there are that many), at most ``maximum``."""
    if len(candidates) == 0:
        return []
    columns = list(components)
    origin = saliency.transform(desired[None, :])[0, columns]
    points = saliency.transform(candidates)[:, columns]
    distances = np.linalg.norm(points - origin, axis=1)
    order = np.argsort(distances, kind="stable")
    radius = epsilon_fraction * float(distances.max())
    chosen = [int(i) for i in order if distances[i] <= radius]
    if len(chosen) < minimum:
        chosen = [int(i) for i in order[: max(1, minimum)]]
    return chosen[:maximum] if maximum else chosen

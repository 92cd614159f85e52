"""A style recognizer for the objective validation (paper §IV-D): which style is this clip?

The paper validates generated motion with a classifier trained on real clips only. Ours:

- **descriptor** (:func:`style_descriptor`): the 27 LMA components plus per-frame
  statistics the LMA maxima summarise away — per point (torso, head, hands, feet) the mean
  and 90th percentile of speed, the mean acceleration and jerk; posture in the body's own
  frame (root-relative, heading of the first frame, arm-length units): head and chest
  height/forward lean, hand height/forward/spread, averaged and at their extremes; timing:
  the clip's duration, the share of frames in motion, the time of peak speed; all
  ``log1p``-compressed where they are magnitudes;
- **normalisation**: style is a modulation of an action, so every descriptor is z-scored
  within its action (mean and spread of that action's training clips; actions with fewer
  than :data:`MIN_ACTION_CLIPS` clips are left out of training), then z-scored overall;
- **classifier**: multinomial logistic regression (L2) with C chosen by stratified 4-fold
  cross-validation over a small grid on the training clips only.

Heavy imports (scikit-learn) happen inside :meth:`StyleRecognizer.fit`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mse.extras import require
from mse.motion.base.bodyparts import body_map
from mse.motion.base.bvh import Motion
from mse.motion.base.kinematics import FloatArray
from mse.motion.base.lma import UP_AXIS, arm_length, body_frame, filtered_derivative, lma_from_positions

#: C grid of the classifier (1/λ of the L2 penalty)
C_GRID = (0.1, 0.3, 1.0)
#: actions with fewer training clips have no usable per-action spread
MIN_ACTION_CLIPS = 3
#: a frame is "in motion" when the summed point speed exceeds this share of its maximum
_MOVING_SHARE = 0.25


def _floor_origin(positions: FloatArray, root: int) -> FloatArray:
    """The first-frame root, on the floor (the clip's lowest point)."""
    origin: FloatArray = positions[0, root].copy()
    origin[UP_AXIS] = positions[..., UP_AXIS].min()
    return origin


def style_descriptor(motion: Motion, *, path: str = "<motion>") -> FloatArray:
    """The recognizer's feature vector of a clip (see the module docstring)."""
    body = body_map(motion.skeleton, path)
    raw = motion.positions()
    positions = raw / arm_length(raw, body)
    dt = motion.frame_time
    lma = np.log1p(np.maximum(lma_from_positions(positions, dt, body).vector(), 0.0))
    local = body_frame(positions, body, _floor_origin(positions, 0))
    points = local[:, list(body.part_indices())]  # (F, 6, 3)
    velocity = filtered_derivative(points, dt)
    acceleration = filtered_derivative(velocity, dt)
    jerk = filtered_derivative(acceleration, dt)
    speed = np.linalg.norm(velocity, axis=-1)
    dynamics = np.concatenate(
        [
            speed.mean(axis=0),
            np.percentile(speed, 90, axis=0),
            np.linalg.norm(acceleration, axis=-1).mean(axis=0),
            np.linalg.norm(jerk, axis=-1).mean(axis=0),
        ]
    )
    total = speed.sum(axis=1)
    peak = float(total.max()) if len(total) else 0.0
    moving = float(np.mean(total > _MOVING_SHARE * peak)) if peak > 1e-9 else 0.0
    peak_time = float(np.argmax(total)) / max(1, len(total) - 1)
    hips = 0.5 * (local[:, body.left_hip] + local[:, body.right_hip])
    head, torso = local[:, body.head], local[:, body.torso]
    hands = local[:, [body.left_hand, body.right_hand]]
    head_rel = head - hips
    torso_rel = torso - hips
    hands_rel = hands - hips[:, None]
    spread = np.linalg.norm(hands[:, 0] - hands[:, 1], axis=-1)
    posture = np.array(
        [
            head[:, 1].mean(),
            head[:, 1].min(),
            head_rel[:, 2].mean(),
            head_rel[:, 2].max(),
            head_rel[:, 1].mean(),
            torso_rel[:, 2].mean(),
            torso_rel[:, 1].mean(),
            hips[:, 1].mean(),
            hands_rel[..., 1].mean(),
            hands_rel[..., 1].max(),
            hands_rel[..., 2].mean(),
            hands_rel[..., 2].max(),
            spread.mean(),
            spread.max(),
            np.linalg.norm(hips[-1, [0, 2]] - hips[0, [0, 2]]),
            hips[:, 1].std(),
        ]
    )
    timing = np.array([np.log(max(motion.duration, 1e-3)), moving, peak_time])
    return np.concatenate([lma, np.log1p(np.maximum(dynamics, 0.0)), posture, timing])


@dataclass(frozen=True, eq=False)
class StyleRecognizer:
    """Per-action z-scored descriptors -> multinomial logistic regression."""

    action_means: dict[str, FloatArray]
    action_scales: dict[str, FloatArray]
    mean: FloatArray
    scale: FloatArray
    model: object
    c: float

    @staticmethod
    def fit(
        descriptors: FloatArray,
        actions: Sequence[str],
        styles: Sequence[str],
        *,
        c: float | None = None,
    ) -> StyleRecognizer:
        """Train on real clips; ``c=None`` picks C from :data:`C_GRID` by stratified 4-fold CV."""
        with require("motion"):
            from sklearn.linear_model import LogisticRegression
            from sklearn.model_selection import StratifiedKFold, cross_val_score

        counts = {a: list(actions).count(a) for a in set(actions)}
        kept = [i for i, a in enumerate(actions) if counts[a] >= MIN_ACTION_CLIPS]
        if len({styles[i] for i in kept}) < 2:  # too few per action: plain z-scores
            kept = list(range(len(actions)))
        data = np.asarray(descriptors, dtype=np.float64)[kept]
        actions = [actions[i] for i in kept]
        styles = [styles[i] for i in kept]
        action_means: dict[str, FloatArray] = {}
        action_scales: dict[str, FloatArray] = {}
        for action in set(actions):
            rows = data[[x == action for x in actions]]
            action_means[action] = rows.mean(axis=0)
            spread = rows.std(axis=0)
            action_scales[action] = np.where(spread > 1e-9, spread, 1.0)
        centred = np.array(
            [(row - action_means[a]) / action_scales[a] for row, a in zip(data, actions, strict=True)]
        )
        mean = centred.mean(axis=0)
        scale = centred.std(axis=0)
        scale[scale < 1e-9] = 1.0
        z = (centred - mean) / scale
        if c is None:
            per_style = np.unique(np.asarray(styles), return_counts=True)[1]
            folds = int(min(4, per_style.min()))
            best = (-1.0, C_GRID[0])
            for candidate in C_GRID:
                model = LogisticRegression(C=candidate, max_iter=3000)
                splitter = StratifiedKFold(folds, shuffle=True, random_state=0)
                score = float(cross_val_score(model, z, list(styles), cv=splitter).mean())
                if score > best[0] + 1e-9:
                    best = (score, candidate)
            c = best[1]
        model = LogisticRegression(C=c, max_iter=3000).fit(z, list(styles))
        return StyleRecognizer(action_means, action_scales, mean, scale, model, c)

    def predict(self, descriptor: FloatArray, action: str, among: Sequence[str] = ()) -> str:
        """The style of a clip of ``action``, restricted to ``among`` when given (a
        recognizer trained on more styles deciding between fewer); an action unseen in
        training gets no per-action normalisation, a weaker guess."""
        if action in self.action_means:
            centred = (descriptor - self.action_means[action]) / self.action_scales[action]
        else:
            centred = self.mean.copy()  # z = 0: the training prior
        z = ((centred - self.mean) / self.scale)[None, :]
        model = self.model
        classes = [str(c) for c in model.classes_]  # type: ignore[attr-defined]
        allowed = [i for i, c in enumerate(classes) if not among or c in among]
        if not allowed:
            raise ValueError(f"none of {list(among)} is a trained style ({classes})")
        scores = model.predict_log_proba(z)[0]  # type: ignore[attr-defined]
        return classes[max(allowed, key=lambda i: float(scores[i]))]

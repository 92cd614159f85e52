"""The space in which the HMM finds the phases of a movement: body-frame joint positions.

The paper models Cartesian marker positions normalised by the performer's arm length.
Here, per frame, the positions of the joints that hang from the hips (the translating joint
and its subtree), relative to the middle of the hips, in the clip's first-frame body frame
(X to the body's left, Y up, Z forward), divided by the arm length.

:class:`PhaseSpace` then keeps the principal components of the neighbours' poses (95 % of
their variance, at most :data:`MAX_COMPONENTS`) and every clip is z-scored on them *by
itself*: what is left is the shape of its movement in time — when the arms rise, when the
head goes down, which way the hands swing — not how far or in which posture. A performer's
stance or a style's amplitude then no longer decides which state a frame belongs to (with
absolute poses, a normal wave decoded against active waves sat in one state for 6 seconds;
with rotations, the desired bow's apex matched an upright state of the angry bow).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mse.motion.base.body_frame import body_of
from mse.motion.base.bvh import Motion, Skeleton
from mse.motion.base.kinematics import FloatArray

MAX_COMPONENTS = 8
VARIANCE_SHARE = 0.95
#: added to a clip's own spread before z-scoring: a dimension the clip does not move stays
#: near zero instead of being blown up to unit variance (units of the neighbours' spread)
SPREAD_FLOOR = 0.05


def _hip_subtree(skeleton: Skeleton, hips: int) -> list[int]:
    keep = []
    for joint in range(skeleton.joint_count):
        ancestor = joint
        while ancestor >= 0 and ancestor != hips:
            ancestor = skeleton.parents[ancestor]
        if ancestor == hips:
            keep.append(joint)
    return keep


def pose_features(motion: Motion) -> FloatArray:
    """(frames, 3 x joints) body-frame positions relative to the hips, in arm lengths."""
    data = body_of(motion)
    body = data.body
    positions = data.positions / data.scale
    middle = 0.5 * (positions[:, body.left_hip] + positions[:, body.right_hip])
    hips = motion.skeleton.parents[body.left_hip]
    relative = positions[:, _hip_subtree(motion.skeleton, hips)] - middle[:, None]
    return relative.reshape(motion.frame_count, -1)


@dataclass(frozen=True, eq=False)
class PhaseSpace:
    """Principal components of the neighbours' poses and their spread."""

    mean: FloatArray  # (D,)
    basis: FloatArray  # (k, D)
    spread: FloatArray  # (k,)

    @property
    def dimension(self) -> int:
        return int(self.basis.shape[0])

    def observe(self, features: FloatArray) -> FloatArray:
        """(frames, k): the clip on the components, z-scored by its own mean and spread."""
        projected = (features - self.mean) @ self.basis.T / self.spread
        if len(projected) == 0:
            return projected
        centred: FloatArray = (projected - projected.mean(axis=0)) / (projected.std(axis=0) + SPREAD_FLOOR)
        return centred


def with_velocity(observed: FloatArray, weight: float = 1.0) -> FloatArray:
    """``observed`` (frames, k) with its velocity (per frame) appended, z-scored by the clip's
    own spread like the positions (plus the same floor, :data:`SPREAD_FLOOR`), times
    ``weight``: a state then tells a hand swinging out from one swinging back, and a hand
    that has stopped at the end of its swing from one passing through the middle."""
    if len(observed) < 2:
        return np.hstack([observed, np.zeros_like(observed)])
    velocity = np.gradient(observed, axis=0)
    velocity = (velocity - velocity.mean(axis=0)) / (velocity.std(axis=0) + SPREAD_FLOOR)
    result: FloatArray = np.hstack([observed, weight * velocity])
    return result


def phase_space(sequences: Sequence[FloatArray]) -> PhaseSpace:
    """Components of the pooled frames of ``sequences`` (each frames x D)."""
    pooled = np.vstack(sequences)
    mean = pooled.mean(axis=0)
    centred = pooled - mean
    if len(pooled) < 2 or not np.any(centred):
        return PhaseSpace(mean, np.eye(pooled.shape[1])[:1], np.ones(1))
    _, values, vectors = np.linalg.svd(centred, full_matrices=False)
    energy = values**2
    share = np.cumsum(energy) / energy.sum()
    count = min(MAX_COMPONENTS, int(np.searchsorted(share, VARIANCE_SHARE)) + 1, len(values))
    basis = vectors[:count]
    spread = np.sqrt(energy[:count] / len(pooled))
    return PhaseSpace(mean, basis, np.where(spread > 1e-9, spread, 1.0))

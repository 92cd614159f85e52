"""LMA Effort and Shape components of a clip (Samadani et al., §III-A).

Every component is computed on world joint positions (forward kinematics) divided by the
performer's arm length (right shoulder -> elbow -> wrist, mean over the clip), with time in
seconds so that clips sampled at 30 and 120 fps are comparable. Six points: the torso and the
end-effectors head, left/right hand, left/right foot (see :mod:`mse.motion.base.bodyparts`); unit
masses for all of them, as in the paper.

- velocity, acceleration and jerk are successive derivatives, each low-pass filtered
  (zero-phase Butterworth, order 2, cut-off 6 Hz or 0.8 x Nyquist; :mod:`mse.motion.base.filters`,
  numpy only) to remove mocap noise;
- **Weight** = max over time of the summed kinetic energy Σ v² (eq. 1-3);
- **Time** = max over time of the summed acceleration magnitudes (eq. 4);
- **Flow** = aggregated jerk Σ_k Σ_i |j_k(t_i)| Δt (eq. 5 with the derivative in seconds,
  i.e. the total variation of the acceleration);
- per part, Weight/Time/Flow are the same formulas on that part alone;
- **Shaping vertical / sagittal** = max displacement of the torso from its first-frame
  position along the up axis / along the body's forward axis (perpendicular to the hips at the
  first frame, in the floor plane);
- **Shaping horizontal** = area of the convex hull of every joint of every frame projected on
  the floor;
- **Shape Flow** = max over frames of the volume of the body's bounding box;
- **Directional** (per hand) = mean curvature |ẋÿ - ẏẍ| / (ẋ² + ẏ² + ε)^{3/2} of the hand path
  in the plane of its two principal components (eq. 6; ε = 1e-2 keeps pauses finite).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from mse.motion.base.bodyparts import PARTS, BodyMap, body_map
from mse.motion.base.bvh import Motion
from mse.motion.base.filters import convex_hull_area, zero_phase_lowpass
from mse.motion.base.kinematics import FloatArray

UP_AXIS = 1  # all three datasets and the starter skeleton are Y-up
WHOLE_BODY_KEYS: tuple[str, ...] = (
    "weight",
    "time",
    "flow",
    "shaping_vertical",
    "shaping_sagittal",
    "shaping_horizontal",
    "shape_flow",
    "directional_left",
    "directional_right",
)
PART_KEYS: tuple[str, ...] = ("weight", "time", "flow")
#: Names of the components of :meth:`LmaFeatures.vector`, in order.
FEATURE_NAMES: tuple[str, ...] = tuple(f"whole_body.{k}" for k in WHOLE_BODY_KEYS) + tuple(
    f"{part}.{k}" for part in PARTS for k in PART_KEYS
)
_CUTOFF_HZ = 6.0
_CURVATURE_EPSILON = 1e-2


@dataclass(frozen=True, slots=True)
class LmaFeatures:
    whole_body: dict[str, float]
    parts: dict[str, dict[str, float]]

    def to_json(self) -> dict[str, Any]:
        return {
            "whole_body": dict(self.whole_body),
            "parts": {p: dict(v) for p, v in self.parts.items()},
        }

    def vector(self) -> FloatArray:
        values = [self.whole_body[k] for k in WHOLE_BODY_KEYS]
        values += [self.parts[p][k] for p in PARTS for k in PART_KEYS]
        return np.array(values, dtype=np.float64)


def body_frame(positions: FloatArray, body: BodyMap, origin: FloatArray) -> FloatArray:
    """Positions relative to ``origin``, rotated so that the body's first-frame forward axis
    is +Z and up is +Y (performers face different ways): rows of the basis are the new X
    (left), Y (up) and Z (forward)."""
    lateral = positions[0, body.left_hip] - positions[0, body.right_hip]
    lateral[UP_AXIS] = 0.0
    norm = float(np.linalg.norm(lateral))
    lateral = lateral / norm if norm > 1e-9 else np.array([1.0, 0.0, 0.0])
    up = np.zeros(3)
    up[UP_AXIS] = 1.0
    forward = np.cross(lateral, up)
    basis = np.stack([lateral, up, forward])
    result: FloatArray = (positions - origin) @ basis.T
    return result


def arm_length(positions: FloatArray, body: BodyMap) -> float:
    upper = np.linalg.norm(positions[:, body.right_elbow] - positions[:, body.right_shoulder], axis=-1)
    lower = np.linalg.norm(positions[:, body.right_wrist] - positions[:, body.right_elbow], axis=-1)
    length = float(np.mean(upper + lower))
    return length if length > 1e-9 else 1.0


def filtered_derivative(signal: FloatArray, frame_time: float) -> FloatArray:
    """Low-pass filtered time derivative along axis 0 (zero-phase, :data:`_CUTOFF_HZ`)."""
    if len(signal) < 2:
        return np.zeros_like(signal)
    derivative: FloatArray = np.gradient(signal, frame_time, axis=0)
    return zero_phase_lowpass(derivative, frame_time, _CUTOFF_HZ)


def _curvature(path: FloatArray, frame_time: float) -> float:
    if len(path) < 3:
        return 0.0
    centred = path - path.mean(axis=0)
    _, _, components = np.linalg.svd(centred, full_matrices=False)
    plane = centred @ components[:2].T
    first = filtered_derivative(plane, frame_time)
    second = filtered_derivative(first, frame_time)
    cross = np.abs(first[:, 0] * second[:, 1] - first[:, 1] * second[:, 0])
    speed_sq = first[:, 0] ** 2 + first[:, 1] ** 2
    return float(np.mean(cross / (speed_sq + _CURVATURE_EPSILON) ** 1.5))


def lma_features(motion: Motion, *, path: str = "<motion>") -> LmaFeatures:
    """The Effort and Shape components of ``motion`` (see the module docstring)."""
    body = body_map(motion.skeleton, path)
    positions = motion.positions()
    positions = positions / arm_length(positions, body)
    return lma_from_positions(positions, motion.frame_time, body)


def lma_from_positions(positions: FloatArray, frame_time: float, body: BodyMap) -> LmaFeatures:
    """Components from normalised world positions (F, J, 3)."""
    points = positions[:, list(body.part_indices())]  # (F, 6, 3) in PARTS order
    velocity = filtered_derivative(points, frame_time)
    acceleration = filtered_derivative(velocity, frame_time)
    jerk = filtered_derivative(acceleration, frame_time)
    energy = np.sum(velocity**2, axis=-1)  # (F, 6), unit masses
    accel = np.linalg.norm(acceleration, axis=-1)
    jerk_norm = np.linalg.norm(jerk, axis=-1)
    parts = {
        part: {
            "weight": float(energy[:, k].max()),
            "time": float(accel[:, k].max()),
            "flow": float(jerk_norm[:, k].sum() * frame_time),
        }
        for k, part in enumerate(PARTS)
    }
    torso = positions[:, body.torso]
    displacement = torso - torso[0]
    lateral = positions[0, body.left_hip] - positions[0, body.right_hip]
    lateral[UP_AXIS] = 0.0
    up = np.zeros(3)
    up[UP_AXIS] = 1.0
    forward = np.cross(lateral, up)
    norm = float(np.linalg.norm(forward))
    forward = forward / norm if norm > 1e-9 else np.array([0.0, 0.0, 1.0])
    floor_axes = [axis for axis in range(3) if axis != UP_AXIS]
    extent = positions.max(axis=1) - positions.min(axis=1)  # (F, 3) bounding boxes
    whole = {
        "weight": float(energy.sum(axis=1).max()),
        "time": float(accel.sum(axis=1).max()),
        "flow": float(jerk_norm.sum() * frame_time),
        "shaping_vertical": float(np.abs(displacement[:, UP_AXIS]).max()),
        "shaping_sagittal": float(np.abs(displacement @ forward).max()),
        "shaping_horizontal": convex_hull_area(positions[:, :, floor_axes].reshape(-1, 2)),
        "shape_flow": float(np.prod(extent, axis=1).max()),
        "directional_left": _curvature(positions[:, body.left_hand], frame_time),
        "directional_right": _curvature(positions[:, body.right_hand], frame_time),
    }
    return LmaFeatures(whole, parts)


def format_text(features: LmaFeatures) -> str:
    """A human-readable table of the components."""
    lines = ["whole body:"]
    lines += [f"  {key:<20} {features.whole_body[key]:12.4f}" for key in WHOLE_BODY_KEYS]
    lines.append(f"{'part':<12}" + "".join(f"{k:>12}" for k in PART_KEYS))
    for part in PARTS:
        values = features.parts[part]
        lines.append(f"{part:<12}" + "".join(f"{values[k]:12.4f}" for k in PART_KEYS))
    return "\n".join(lines) + "\n"

"""Tracks as an OpenFace 2.0 FeatureExtraction CSV: its 714 columns, order and number format.

Columns (OpenFace wiki, "Output Format"): ``frame, face_id, timestamp, confidence, success``,
both eyes' gaze vectors and the gaze angles, 56 eye landmarks (2-D and 3-D), head pose
(``pose_Tx..Tz`` in mm, ``pose_Rx..Rz`` in radians), 68 face landmarks (2-D and 3-D), the
shape model's 40 parameters, 17 ``AUxx_r`` intensities (0-5) and 18 ``AUxx_c`` presences.
Fields are separated by ``", "`` as OpenFace writes them.  Landmarks and shape parameters
are those of one neutral face, the same on every row (a track carries no geometry); Greta's
reader ignores them but keeps only rows with all 714 fields.

Values: ``AUxx_r`` = the track's unit xx (AU45, the blink, is the face player's AU43 eye
closure: OpenFace has no AU43), ``AUxx_c`` = 1 while ``AUxx_r`` is above 0 (AU28 has no
curve: 0); gaze vectors point along the gaze angles (camera coordinates: x right, y down,
z away from the camera; looking at the camera is (0, 0, -1)); ``pose_Rx`` = pitch,
``pose_Ry`` = -yaw, ``pose_Rz`` = roll (the agent's left is the camera's right).
"""

from __future__ import annotations

import math

import numpy as np

from mse.export.options import ExportOptions
from mse.export.tracks.model import Tracks, sample
from mse.timeline import Timeline

#: OpenFace 2.0's action units with an intensity (``_r``) and with a presence (``_c``) column.
AU_INTENSITY: tuple[int, ...] = (1, 2, 4, 5, 6, 7, 9, 10, 12, 14, 15, 17, 20, 23, 25, 26, 45)
AU_PRESENCE: tuple[int, ...] = (1, 2, 4, 5, 6, 7, 9, 10, 12, 14, 15, 17, 20, 23, 25, 26, 28, 45)
#: OpenFace units drawn by another unit of the face player (AU45 blink: AU43 eye closure).
DRAWN_AS: dict[int, int] = {45: 43}
#: Distance of the face from the camera (mm) in ``pose_Tz`` and the 3-D landmarks.
DISTANCE_MM = 500.0
CONFIDENCE = 0.98


def columns() -> list[str]:
    """The 714 column names in OpenFace 2.0's order."""
    names = ["frame", "face_id", "timestamp", "confidence", "success"]
    names += [f"gaze_{eye}_{axis}" for eye in (0, 1) for axis in "xyz"] + ["gaze_angle_x", "gaze_angle_y"]
    names += [f"eye_lmk_{axis}_{i}" for axis in "xyXYZ" for i in range(56)]
    names += ["pose_Tx", "pose_Ty", "pose_Tz", "pose_Rx", "pose_Ry", "pose_Rz"]
    names += [f"{axis}_{i}" for axis in "xyXYZ" for i in range(68)]
    names += ["p_scale", "p_rx", "p_ry", "p_rz", "p_tx", "p_ty"] + [f"p_{i}" for i in range(34)]
    names += [f"AU{n:02d}_r" for n in AU_INTENSITY] + [f"AU{n:02d}_c" for n in AU_PRESENCE]
    return names


def _neutral_face() -> list[tuple[float, float]]:
    """68 points of a front-facing neutral face (iBUG layout), in mm around the nose tip."""
    points: list[tuple[float, float]] = []
    for i in range(17):  # jaw, from the image's left ear to its right
        angle = math.pi * (1.0 - i / 16.0)
        points.append((70.0 * math.cos(angle), 10.0 + 70.0 * abs(math.sin(angle))))
    for side in (-1.0, 1.0):  # brows, image-left then image-right
        for i in range(5):
            x = side * (15.0 + 10.0 * i) if side > 0 else side * (55.0 - 10.0 * i)
            points.append((x, -45.0 - 4.0 * math.sin(math.pi * i / 4.0)))
    points += [(0.0, -35.0 + 10.0 * i) for i in range(4)]  # nose bridge
    points += [(-10.0 + 5.0 * i, 8.0 + (2.0 if i in (0, 4) else 4.0)) for i in range(5)]  # nose base
    for centre in (-30.0, 30.0):  # eyes: corner, upper lid, corner, lower lid
        for i in range(6):
            angle = math.pi * i / 3.0
            points.append((centre - 12.0 * math.cos(angle), -25.0 - 5.0 * math.sin(angle)))
    for i in range(12):  # outer lip
        angle = math.pi * i / 6.0
        points.append((-25.0 * math.cos(angle), 38.0 - 9.0 * math.sin(angle)))
    for i in range(8):  # inner lip
        angle = math.pi * i / 4.0
        points.append((-18.0 * math.cos(angle), 38.0 - 3.0 * math.sin(angle)))
    return points


def _constant_fields() -> tuple[str, str]:
    """The eye-landmark block and the face-landmark + shape-parameter block (same every row)."""
    focal, cx, cy = 500.0, 320.0, 240.0

    def project(x: float, y: float) -> tuple[float, float]:
        return cx + focal * x / DISTANCE_MM, cy + focal * y / DISTANCE_MM

    eyes = [
        (c + 6.0 * math.cos(2 * math.pi * i / 28), -25.0 + 4.0 * math.sin(2 * math.pi * i / 28))
        for c in (-30.0, 30.0)
        for i in range(28)
    ]
    face = _neutral_face()

    def block(points: list[tuple[float, float]]) -> list[str]:
        image = [project(x, y) for x, y in points]
        fields = [f"{u:.1f}" for u, _ in image] + [f"{v:.1f}" for _, v in image]
        fields += [f"{x:.1f}" for x, _ in points] + [f"{y:.1f}" for _, y in points]
        return fields + [f"{DISTANCE_MM:.1f}"] * len(points)

    shape = [f"{v:.3f}" for v in (1.0, 0.0, 0.0, 0.0, cx, cy)] + ["0.000"] * 34
    return ", ".join(block(eyes)), ", ".join(block(face) + shape)


def openface_values(tracks: Tracks) -> dict[str, np.ndarray]:
    """Column -> values over the frames, for the columns that change (the numbers written)."""
    gx = np.radians(tracks.gaze[:, 0])
    gy = np.radians(tracks.gaze[:, 1])
    vector = np.stack([np.tan(gx), np.tan(gy), -np.ones_like(gx)], axis=1)
    vector /= np.linalg.norm(vector, axis=1, keepdims=True)
    pitch, yaw, roll = (np.radians(tracks.head[:, i]) for i in range(3))
    values: dict[str, np.ndarray] = {
        "timestamp": tracks.times,
        **{f"gaze_{eye}_{axis}": vector[:, a] for eye in (0, 1) for a, axis in enumerate("xyz")},
        "gaze_angle_x": np.arctan2(vector[:, 0], -vector[:, 2]),
        "gaze_angle_y": np.arctan2(vector[:, 1], -vector[:, 2]),
        "pose_Rx": pitch,
        "pose_Ry": -yaw,
        "pose_Rz": roll,
    }
    au = tracks.au
    for n in AU_INTENSITY:
        unit = DRAWN_AS.get(n, n)
        intensity = au[:, tracks.units.index(unit)] if unit in tracks.units else np.zeros(tracks.frame_count)
        values[f"AU{n:02d}_r"] = np.round(intensity, 2)
    for n in AU_PRESENCE:
        measured = values.get(f"AU{n:02d}_r")
        values[f"AU{n:02d}_c"] = np.zeros(tracks.frame_count) if measured is None else (measured > 0).astype(float)
    return values


def write_openface(tracks: Tracks) -> str:
    """The CSV text (header and one row per frame)."""
    eyes, face = _constant_fields()
    values = openface_values(tracks)
    count = tracks.frame_count

    def formatted(name: str, digits: int) -> list[str]:
        column = values[name]
        if not column.any():  # most units rest most of the time
            return [f"{0.0:.{digits}f}"] * count
        return [f"{v:.{digits}f}" for v in column.tolist()]

    gaze = [formatted(f"gaze_{eye}_{axis}", 6) for eye in (0, 1) for axis in "xyz"]
    gaze += [formatted("gaze_angle_x", 3), formatted("gaze_angle_y", 3)]
    pose = [formatted(name, 3) for name in ("pose_Rx", "pose_Ry", "pose_Rz")]
    units = [formatted(f"AU{n:02d}_r", 2) for n in AU_INTENSITY] + [formatted(f"AU{n:02d}_c", 2) for n in AU_PRESENCE]
    head = [f"{k + 1}, 0, {t:.3f}, {CONFIDENCE:.2f}, 1" for k, t in enumerate(values["timestamp"].tolist())]
    middle = f"{eyes}, 0.0, 0.0, {DISTANCE_MM:.1f}"
    rows = [", ".join(columns())]
    for k in range(count):
        rows.append(
            ", ".join(
                [head[k], *(column[k] for column in gaze), middle, *(column[k] for column in pose), face]
                + [column[k] for column in units]
            )
        )
    return "\n".join(rows) + "\n"


def render_openface(timeline: Timeline, options: ExportOptions) -> str:
    return write_openface(sample(timeline, options))

"""Tracks as ARKit blendshape weights: a CSV in the layout of Live Link Face recordings and
a JSON form ``{fps, names, frames}``.

CSV columns: ``Timecode`` (``HH:MM:SS:FF.mmm`` from 0, FF the frame within the second),
``BlendShapeCount`` (61: the 52 blendshapes and 9 rotations), Apple's 52 names (``arkit.toml``,
Apple's spelling and order), then ``HeadYaw, HeadPitch, HeadRoll, LeftEyeYaw, LeftEyePitch,
LeftEyeRoll, RightEyeYaw, RightEyePitch, RightEyeRoll`` in radians (yaw > 0 to the agent's
left, pitch > 0 down, roll > 0 to the agent's left; both eyes turn alike, roll 0).
"""

from __future__ import annotations

import json
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cache
from importlib import resources

import numpy as np

from mse.export.face.rig import FloatArray
from mse.export.options import ExportOptions
from mse.export.tracks.model import GAZE_DEGREES, Tracks, sample
from mse.timeline import Timeline

ROTATIONS: tuple[str, ...] = (
    "HeadYaw",
    "HeadPitch",
    "HeadRoll",
    "LeftEyeYaw",
    "LeftEyePitch",
    "LeftEyeRoll",
    "RightEyeYaw",
    "RightEyePitch",
    "RightEyeRoll",
)


@dataclass(frozen=True)
class ArkitTable:
    names: tuple[str, ...]
    #: AU number -> ((blendshape index, side index or None for the stronger side, weight), ...)
    units: Mapping[int, tuple[tuple[int, int | None, float], ...]]


@cache
def arkit_table() -> ArkitTable:
    text = resources.files("mse.export.tracks").joinpath("arkit.toml").read_text(encoding="utf-8")
    data = tomllib.loads(text)
    names = tuple(str(n) for n in data["names"])
    index = {name: i for i, name in enumerate(names)}
    units: dict[int, tuple[tuple[int, int | None, float], ...]] = {}
    for number, moves in data["units"].items():
        entries: list[tuple[int, int | None, float]] = []
        for name, weight in moves.items():
            if name.endswith("*"):
                entries += [(index[name[:-1] + side], s, float(weight)) for s, side in enumerate(("Left", "Right"))]
            else:
                entries.append((index[name], None, float(weight)))
        units[int(number)] = tuple(entries)
    return ArkitTable(names, units)


def blendshapes(tracks: Tracks) -> FloatArray:
    """Weights ``[frames, 52]`` in Apple's order (see ``arkit.toml``)."""
    table = arkit_table()
    index = {name: i for i, name in enumerate(table.names)}
    weights = np.zeros((tracks.frame_count, len(table.names)))
    for u, number in enumerate(tracks.units):
        for shape, side, weight in table.units.get(number, ()):
            source = tracks.sides[:, u, :].max(axis=1) if side is None else tracks.sides[:, u, side]
            weights[:, shape] += weight * source
    gx = np.clip(tracks.gaze[:, 0] / GAZE_DEGREES, -1.0, 1.0)
    gy = np.clip(tracks.gaze[:, 1] / GAZE_DEGREES, -1.0, 1.0)
    left, right = np.clip(gx, 0.0, 1.0), np.clip(-gx, 0.0, 1.0)  # towards the agent's left / right
    weights[:, index["eyeLookOutLeft"]] += left
    weights[:, index["eyeLookInRight"]] += left
    weights[:, index["eyeLookInLeft"]] += right
    weights[:, index["eyeLookOutRight"]] += right
    for eye in ("Left", "Right"):
        weights[:, index[f"eyeLookDown{eye}"]] += np.clip(gy, 0.0, 1.0)
        weights[:, index[f"eyeLookUp{eye}"]] += np.clip(-gy, 0.0, 1.0)
    result: FloatArray = np.clip(weights, 0.0, 1.0)
    return result


def rotations(tracks: Tracks) -> FloatArray:
    """``[frames, 9]`` radians in the order of :data:`ROTATIONS`."""
    pitch, yaw, roll = (np.radians(tracks.head[:, i]) for i in range(3))
    eye_yaw, eye_pitch = np.radians(tracks.gaze[:, 0]), np.radians(tracks.gaze[:, 1])
    zero = np.zeros(tracks.frame_count)
    result: FloatArray = np.stack([yaw, pitch, roll, eye_yaw, eye_pitch, zero, eye_yaw, eye_pitch, zero], axis=1)
    return result


def timecode(time: float, fps: float) -> str:
    frame = round(time * fps)
    seconds, ff = divmod(frame, round(fps))
    minutes, ss = divmod(seconds, 60)
    hh, mm = divmod(minutes, 60)
    milliseconds = round((time - frame / fps) * 1000.0) % 1000
    return f"{hh:02d}:{mm:02d}:{ss:02d}:{ff:02d}.{milliseconds:03d}"


def write_arkit_csv(tracks: Tracks) -> str:
    names = arkit_table().names
    columns = np.concatenate([blendshapes(tracks), rotations(tracks)], axis=1)
    count = str(columns.shape[1])
    rows = [",".join(("Timecode", "BlendShapeCount", *names, *ROTATIONS))]
    for time, row in zip(tracks.times.tolist(), columns.tolist(), strict=True):
        rows.append(",".join([timecode(time, tracks.fps), count, *("0.000000" if v == 0 else f"{v:.6f}" for v in row)]))
    return "\n".join(rows) + "\n"


def write_arkit_json(tracks: Tracks) -> str:
    names = arkit_table().names
    columns = np.round(np.concatenate([blendshapes(tracks), rotations(tracks)], axis=1), 6) + 0.0
    document = {"fps": tracks.fps, "names": [*names, *ROTATIONS], "frames": columns.tolist()}
    return json.dumps(document, separators=(",", ":")) + "\n"


def render_arkit(timeline: Timeline, options: ExportOptions) -> str:
    return write_arkit_csv(sample(timeline, options))


def render_arkit_json(timeline: Timeline, options: ExportOptions) -> str:
    return write_arkit_json(sample(timeline, options))

"""Tracks as a VRM animation (``.vrma``): binary glTF 2.0 with the ``VRMC_vrm_animation`` extension.

Nodes: a humanoid chain ``hips`` (rest at 0.85 m) - ``spine`` - ``chest`` - ``neck`` - ``head``,
one node per expression and a ``lookAt`` node.  One animation, LINEAR, a key per frame:

- expressions (weight = the node's translation x, as VRMC_vrm_animation says): the presets of
  ``vrma.toml`` (happy, angry, sad, surprised) from their units, ``blink``/``blinkLeft``/
  ``blinkRight`` from AU43, ``lookUp/Down/Left/Right`` from the gaze, and a custom expression
  ``AU<n>`` for every other unit of the face player (intensity / 5);
- ``neck`` and ``head`` rotations share the head rotation (40 % and 60 %), ``lookAt`` turns by
  the gaze angles.  glTF axes: y up, the avatar faces +z, its left is +x: yaw turns about +y,
  pitch (> 0 down) about +x, roll (> 0 to the agent's left) about -z.
"""

from __future__ import annotations

import json
import struct
import tomllib
from functools import cache
from importlib import resources

import numpy as np

from mse.export.face.rig import FloatArray
from mse.export.options import ExportOptions
from mse.export.tracks.model import AU_SCALE, GAZE_DEGREES, Tracks, sample
from mse.timeline import Timeline

#: Share of the head rotation carried by the neck (the head carries the rest).
NECK_SHARE = 0.4
_BONES = (("hips", (0.0, 0.85, 0.0)), ("spine", (0.0, 0.1, 0.0)), ("chest", (0.0, 0.15, 0.0)),
          ("neck", (0.0, 0.3, 0.0)), ("head", (0.0, 0.1, 0.0)))  # fmt: skip
_FLOAT = 5126


@cache
def presets() -> dict[str, dict[int, float]]:
    text = resources.files("mse.export.tracks").joinpath("vrma.toml").read_text(encoding="utf-8")
    table = tomllib.loads(text)["presets"]
    return {name: {int(n): float(w) for n, w in units.items()} for name, units in table.items()}


def expression_weights(tracks: Tracks) -> tuple[dict[str, FloatArray], dict[str, FloatArray]]:
    """(preset name -> weights, custom name -> weights) over the frames, 0-1."""
    level = tracks.au / AU_SCALE
    index = {n: i for i, n in enumerate(tracks.units)}
    preset: dict[str, FloatArray] = {}
    used: set[int] = set()
    for name, units in presets().items():
        weight = np.zeros(tracks.frame_count)
        for number, share in units.items():
            if number in index:
                weight += share * level[:, index[number]]
                used.add(number)
        preset[name] = np.clip(weight, 0.0, 1.0)
    if 43 in index:
        sides = tracks.sides[:, index[43], :]
        preset["blink"] = np.clip(sides.max(axis=1), 0.0, 1.0)
        preset["blinkLeft"], preset["blinkRight"] = np.clip(sides[:, 0], 0, 1), np.clip(sides[:, 1], 0, 1)
        used.add(43)
    gx, gy = tracks.gaze[:, 0] / GAZE_DEGREES, tracks.gaze[:, 1] / GAZE_DEGREES
    preset["lookLeft"], preset["lookRight"] = np.clip(gx, 0.0, 1.0), np.clip(-gx, 0.0, 1.0)
    preset["lookDown"], preset["lookUp"] = np.clip(gy, 0.0, 1.0), np.clip(-gy, 0.0, 1.0)
    custom = {f"AU{n}": np.clip(level[:, index[n]], 0.0, 1.0) for n in tracks.units if n not in used}
    return preset, custom


def _quaternions(yaw: FloatArray, pitch: FloatArray, roll: FloatArray) -> FloatArray:
    """Unit quaternions (x, y, z, w) of R_yaw(+y) R_pitch(+x) R_roll(-z), angles in degrees."""

    def axis(angle: FloatArray, vector: tuple[float, float, float]) -> FloatArray:
        half = np.radians(angle) / 2.0
        s = np.sin(half)
        result: FloatArray = np.stack([vector[0] * s, vector[1] * s, vector[2] * s, np.cos(half)], axis=1)
        return result

    def product(a: FloatArray, b: FloatArray) -> FloatArray:
        ax, ay, az, aw = a.T
        bx, by, bz, bw = b.T
        result: FloatArray = np.stack([
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ], axis=1)  # fmt: skip
        return result

    q = product(product(axis(yaw, (0.0, 1.0, 0.0)), axis(pitch, (1.0, 0.0, 0.0))), axis(roll, (0.0, 0.0, -1.0)))
    unit: FloatArray = q / np.linalg.norm(q, axis=1, keepdims=True)
    return unit


class _Binary:
    """The BIN chunk and its buffer views and accessors."""

    def __init__(self) -> None:
        self.data = bytearray()
        self.views: list[dict[str, int]] = []
        self.accessors: list[dict[str, object]] = []

    def add(self, values: FloatArray, kind: str, bounds: bool = False) -> int:
        block = np.ascontiguousarray(values, dtype="<f4").tobytes()
        self.views.append({"buffer": 0, "byteOffset": len(self.data), "byteLength": len(block)})
        self.data += block
        accessor: dict[str, object] = {
            "bufferView": len(self.views) - 1, "componentType": _FLOAT, "count": len(values), "type": kind,
        }  # fmt: skip
        if bounds:
            stored = np.asarray(values, dtype="<f4").reshape(len(values), -1)
            accessor["min"] = [float(v) for v in stored.min(axis=0)]
            accessor["max"] = [float(v) for v in stored.max(axis=0)]
        self.accessors.append(accessor)
        return len(self.accessors) - 1


def write_vrma(tracks: Tracks) -> bytes:
    nodes: list[dict[str, object]] = []
    for i, (name, translation) in enumerate(_BONES):
        node: dict[str, object] = {"name": name, "translation": list(translation)}
        if i + 1 < len(_BONES):
            node["children"] = [i + 1]
        nodes.append(node)
    human = {name: {"node": i} for i, (name, _) in enumerate(_BONES)}
    preset, custom = expression_weights(tracks)
    binary = _Binary()
    times = binary.add(tracks.times, "SCALAR", bounds=True)
    samplers: list[dict[str, object]] = []
    channels: list[dict[str, object]] = []

    def animate(node: int, path: str, values: FloatArray, kind: str) -> None:
        samplers.append({"input": times, "output": binary.add(values, kind), "interpolation": "LINEAR"})
        channels.append({"sampler": len(samplers) - 1, "target": {"node": node, "path": path}})

    expressions: dict[str, dict[str, dict[str, int]]] = {"preset": {}, "custom": {}}
    for group, weights in (("preset", preset), ("custom", custom)):
        for name, weight in weights.items():
            nodes.append({"name": name})
            expressions[group][name] = {"node": len(nodes) - 1}
            zeros = np.zeros_like(weight)
            animate(len(nodes) - 1, "translation", np.stack([weight, zeros, zeros], axis=1), "VEC3")
    pitch, yaw, roll = tracks.head[:, 0], tracks.head[:, 1], tracks.head[:, 2]
    animate(3, "rotation", _quaternions(NECK_SHARE * yaw, NECK_SHARE * pitch, NECK_SHARE * roll), "VEC4")
    rest = 1.0 - NECK_SHARE
    animate(4, "rotation", _quaternions(rest * yaw, rest * pitch, rest * roll), "VEC4")
    nodes.append({"name": "lookAt", "translation": [0.0, 1.5, 0.0]})
    look = len(nodes) - 1
    zero = np.zeros(tracks.frame_count)
    animate(look, "rotation", _quaternions(tracks.gaze[:, 0], tracks.gaze[:, 1], zero), "VEC4")
    extension = {
        "specVersion": "1.0",
        "humanoid": {"humanBones": human},
        "expressions": {k: v for k, v in expressions.items() if v},
        "lookAt": {"node": look},
    }
    document = {
        "asset": {"version": "2.0", "generator": "mse (docs/tracks.md)"},
        "extensionsUsed": ["VRMC_vrm_animation"],
        "extensions": {"VRMC_vrm_animation": extension},
        "scene": 0,
        "scenes": [{"nodes": [0, *range(len(_BONES), len(nodes))]}],
        "nodes": nodes,
        "animations": [{"name": "mse", "samplers": samplers, "channels": channels}],
        "accessors": binary.accessors,
        "bufferViews": binary.views,
        "buffers": [{"byteLength": len(binary.data)}],
    }
    text = json.dumps(document, separators=(",", ":")).encode("utf-8")
    text += b" " * (-len(text) % 4)
    data = bytes(binary.data) + b"\0" * (-len(binary.data) % 4)
    total = 12 + 8 + len(text) + 8 + len(data)
    return b"".join([
        struct.pack("<4sII", b"glTF", 2, total),
        struct.pack("<I4s", len(text), b"JSON"), text,
        struct.pack("<I4s", len(data), b"BIN\0"), data,
    ])  # fmt: skip


def render_vrma(timeline: Timeline, options: ExportOptions) -> bytes:
    return write_vrma(sample(timeline, options))


__all__ = ["render_vrma", "write_vrma"]

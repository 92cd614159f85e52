"""The face rig: one description of the face geometry, compiled and evaluated with numpy.

``rig.json`` (beside this module) is the source: named 3-D points (``.L`` points, on the
agent's left, are mirrored to ``.R``), per-channel displacements of those points (FACS
action units, gaze, shrug) and the shapes drawn through them.  :func:`compile_rig` expands
it into flat arrays; :meth:`Rig.to_json` is what the HTML viewer's ``face.js`` evaluates,
with the same arithmetic as :func:`pose_points` and :func:`shape_paths` here, so that the
page and the video draw the same face (``tests/test_face_rig.py`` and the browser tests
compare the two).

Evaluation, for channel values ``v`` (one number per channel)::

    p = base + sum_c v[c] * delta[c]                      # model units, y down, z to the viewer
    p = p + w * (R_head (p - head_pivot) + head_pivot + (0, 0, forward) - p)   # w: head weight
    p = R_torso (p - torso_pivot) + torso_pivot + (0, 0, torso_forward)
    screen = origin + focal / (focal - p.z) * (p.x, p.y)

``R = R_yaw @ R_pitch @ R_roll`` (degrees; yaw > 0 turns to the agent's left, pitch > 0
looks down, roll > 0 tilts the head to the agent's left).  Shapes are smooth curves through
their points (Catmull-Rom tangents, written as cubic Béziers; ``corners`` break the
tangent) or ellipses from a centre and two axis points.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cache
from importlib import resources
from typing import Any

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]

#: Channels that move or turn whole groups of points instead of displacing some.
TRANSFORM_CHANNELS: tuple[str, ...] = (
    "head_yaw",
    "head_pitch",
    "head_roll",
    "head_forward",
    "torso_pitch",
    "torso_roll",
    "torso_forward",
)
SIDES = ("L", "R")
_SIDED = re.compile(r"^AU\d+$")
#: Points ``hand.<place>.L`` are where a hand goes; ``hand.rest`` is where it hangs.
_PLACE = re.compile(r"^hand\.([a-z_]+)\.L$")
REST_PLACE = "rest"


def hand_channel(side: str, place: str) -> str:
    """The channel that moves the hand of ``side`` (``L``/``R``, the agent's) to ``place``."""
    return f"hand_{side}@{place}"
_KAPPA = 0.5522847498  # cubic Bézier handle length of a quarter ellipse


@dataclass(frozen=True)
class Shape:
    """One drawn shape: a curve through points or an ellipse (centre, x-axis, y-axis point)."""

    id: str
    kind: str  # "curve" | "ellipse"
    points: tuple[int, ...]
    closed: bool
    corners: tuple[bool, ...]
    fill: str | None
    stroke: str | None
    width: float
    opacity: float
    opacity_weights: tuple[tuple[int, float], ...]  # (channel index, weight)

    def to_json(self) -> dict[str, Any]:
        return {
            "id": self.id,
            "kind": self.kind,
            "points": list(self.points),
            "closed": self.closed,
            "corners": [int(c) for c in self.corners],
            "fill": self.fill,
            "stroke": self.stroke,
            "width": self.width,
            "opacity": self.opacity,
            "weights": [[c, w] for c, w in self.opacity_weights],
        }


@dataclass(frozen=True)
class Rig:
    """A compiled face: ``base[n] = (x, y, z)``, ``deltas[c, n] = (dx, dy, dz)``."""

    names: tuple[str, ...]
    base: FloatArray
    head_weight: FloatArray
    channels: tuple[str, ...]
    deltas: FloatArray
    shapes: tuple[Shape, ...]
    view_box: tuple[float, float]
    origin: tuple[float, float]
    focal: float
    head_pivot: tuple[float, float, float]
    torso_pivot: tuple[float, float, float]
    background: str
    #: Hand places (points ``hand.<place>.L``/``.R``); each has a weight channel per side.
    places: tuple[str, ...] = ()
    #: The half-body view's source (``rig.json``'s ``half_body``), compiled by
    #: :func:`mse.export.face.body.half_body`.
    half_body_source: Mapping[str, Any] | None = None

    @property
    def channel_index(self) -> dict[str, int]:
        return {name: index for index, name in enumerate(self.channels)}

    def zero(self) -> FloatArray:
        return np.zeros(len(self.channels))

    def to_json(self) -> dict[str, Any]:
        """The compiled rig for the page: sparse deltas, numbers rounded to 0.001."""
        sparse: list[list[list[float]]] = []
        for channel in range(len(self.channels)):
            rows = []
            for point in np.flatnonzero(np.any(self.deltas[channel] != 0.0, axis=1)):
                dx, dy, dz = (round(float(v), 3) for v in self.deltas[channel, point])
                rows.append([int(point), dx, dy, dz])
            sparse.append(rows)
        return {
            "names": list(self.names),
            "base": [[round(float(v), 3) for v in row] for row in self.base],
            "headWeight": [round(float(v), 3) for v in self.head_weight],
            "channels": list(self.channels),
            "deltas": sparse,
            "shapes": [s.to_json() for s in self.shapes],
            "viewBox": list(self.view_box),
            "origin": list(self.origin),
            "focal": self.focal,
            "headPivot": list(self.head_pivot),
            "torsoPivot": list(self.torso_pivot),
            "background": self.background,
        }


# -- compiling the source ------------------------------------------------------------------
def _mirror_name(name: str) -> str | None:
    return name[:-2] + ".R" if name.endswith(".L") else None


def _side(name: str) -> str | None:
    return name[-1] if name.endswith((".L", ".R")) else None


def _channel_targets(channel: str, point_side: str | None) -> list[tuple[str, float]]:
    """Sided channels (AUs) split by side; centre points take half of each side."""
    if not _SIDED.match(channel):
        return [(channel, 1.0)]
    if point_side is None:
        return [(f"{channel}:L", 0.5), (f"{channel}:R", 0.5)]
    return [(f"{channel}:{point_side}", 1.0)]


def compile_rig(source: Mapping[str, Any]) -> Rig:
    """Expand mirrored points, deltas and shapes into arrays (see the module docstring)."""
    points: dict[str, list[float]] = {}
    for name, value in source["points"].items():
        x, y, z, *rest = (float(v) for v in value)
        weight = rest[0] if rest else 1.0
        points[name] = [x, y, z, weight]
        twin = _mirror_name(name)
        if twin is not None and twin not in source["points"]:
            points[twin] = [-x, y, z, weight]
    names = tuple(points)
    index = {name: i for i, name in enumerate(names)}
    base = np.array([p[:3] for p in points.values()], dtype=np.float64)
    head_weight = np.array([p[3] for p in points.values()], dtype=np.float64)

    no_mirror = set(source.get("no_mirror", ()))
    channel_names: list[str] = []
    for channel in source["deltas"]:
        for target, _ in _channel_targets(channel, "L") + _channel_targets(channel, "R"):
            if target not in channel_names:
                channel_names.append(target)
    # Hand places: weight channels that displace no point (the half-body view reads them).
    places = tuple(sorted(m.group(1) for n in names if (m := _PLACE.match(n)) and m.group(1) != REST_PLACE))
    channel_names.extend(hand_channel(side, place) for place in places for side in SIDES)
    channel_names.extend(TRANSFORM_CHANNELS)
    channel_index = {name: i for i, name in enumerate(channel_names)}
    deltas = np.zeros((len(channel_names), len(names), 3))
    for channel, moves in source["deltas"].items():
        for name, (dx, dy, dz) in moves.items():
            placements = [(name, float(dx))]
            twin = _mirror_name(name)
            if twin is not None and twin not in moves:
                placements.append((twin, float(dx) if channel in no_mirror else -float(dx)))
            for point_name, x_move in placements:
                for target, share in _channel_targets(channel, _side(point_name)):
                    deltas[channel_index[target], index[point_name]] += share * np.array([x_move, dy, dz])

    shapes: list[Shape] = []
    for spec in source["shapes"]:
        shapes.append(compile_shape(spec, index, channel_index))
        twin = _mirror_name(spec["id"])
        if twin is not None:
            mirrored = dict(spec, id=twin)
            key = "curve" if "curve" in spec else "ellipse"
            mirrored[key] = [_mirror_name(p) or p for p in spec[key]]
            if "corners" in spec:
                mirrored["corners"] = [_mirror_name(p) or p for p in spec["corners"]]
            shapes.append(compile_shape(mirrored, index, channel_index))
    view = source["view"]
    return Rig(
        names=names,
        base=base,
        head_weight=head_weight,
        channels=tuple(channel_names),
        deltas=deltas,
        shapes=tuple(shapes),
        view_box=(float(view["box"][0]), float(view["box"][1])),
        origin=(float(view["origin"][0]), float(view["origin"][1])),
        focal=float(view["focal"]),
        head_pivot=tuple(float(v) for v in source["pivots"]["head"]),  # type: ignore[arg-type]
        torso_pivot=tuple(float(v) for v in source["pivots"]["torso"]),  # type: ignore[arg-type]
        background=str(view.get("background", "#ffffff")),
        places=places,
        half_body_source=source.get("half_body"),
    )


def compile_shape(spec: Mapping[str, Any], index: Mapping[str, int], channels: Mapping[str, int]) -> Shape:
    kind = "curve" if "curve" in spec else "ellipse"
    members = [index[name] for name in spec[kind]]
    corner_names = set(spec.get("corners", ()))
    side = _side(spec["id"])
    weights: dict[int, float] = {}
    for channel, weight in spec.get("opacity_from", {}).items():
        for target, share in _channel_targets(channel, side):
            position = channels[target]
            weights[position] = weights.get(position, 0.0) + share * float(weight)
    return Shape(
        id=spec["id"],
        kind=kind,
        points=tuple(members),
        closed=bool(spec.get("closed", kind == "ellipse")),
        corners=tuple(name in corner_names for name in spec[kind]),
        fill=spec.get("fill"),
        stroke=spec.get("stroke"),
        width=float(spec.get("width", 0.0)),
        opacity=float(spec.get("opacity", 1.0)),
        opacity_weights=tuple(sorted(weights.items())),
    )


@cache
def default_rig() -> Rig:
    """The face shipped with mse (``mse/export/face/rig.json``)."""
    text = resources.files("mse.export.face").joinpath("rig.json").read_text(encoding="utf-8")
    return compile_rig(json.loads(text))


# -- evaluation ---------------------------------------------------------------------------
def rotation(yaw: float, pitch: float, roll: float) -> FloatArray:
    """``R_yaw @ R_pitch @ R_roll`` in the rig's axes (x right, y down, z to the viewer)."""
    cy, sy = math.cos(math.radians(yaw)), math.sin(math.radians(yaw))
    cp, sp = math.cos(math.radians(pitch)), math.sin(math.radians(pitch))
    cr, sr = math.cos(math.radians(roll)), math.sin(math.radians(roll))
    # yaw > 0: the front (z > 0) moves to +x; pitch > 0: the front moves down (+y);
    # roll > 0: the top (y < 0) moves to +x.
    r_yaw = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
    r_pitch = np.array([[1.0, 0.0, 0.0], [0.0, cp, sp], [0.0, -sp, cp]])
    r_roll = np.array([[cr, -sr, 0.0], [sr, cr, 0.0], [0.0, 0.0, 1.0]])
    matrix: FloatArray = r_yaw @ r_pitch @ r_roll
    return matrix


def pose_points(rig: Rig, values: FloatArray) -> FloatArray:
    """Screen positions ``[n, 2]`` (view-box units) for channel values ``values``."""
    return project(rig, pose_model(rig, values))


def project(rig: Rig, p: FloatArray) -> FloatArray:
    """Model points ``[n, 3]`` to screen positions ``[n, 2]`` (the rig's perspective)."""
    scale = rig.focal / (rig.focal - p[:, 2])
    return np.stack([rig.origin[0] + scale * p[:, 0], rig.origin[1] + scale * p[:, 1]], axis=1)


def pose_model(rig: Rig, values: FloatArray) -> FloatArray:
    """Posed model points ``[n, 3]`` (before the perspective) for channel values ``values``."""
    n_delta = len(rig.channels) - len(TRANSFORM_CHANNELS)
    p = rig.base + np.tensordot(values[:n_delta], rig.deltas[:n_delta], axes=1)
    yaw, pitch, roll, forward, t_pitch, t_roll, t_forward = (float(v) for v in values[n_delta:])
    pivot = np.array(rig.head_pivot)
    turned = (p - pivot) @ rotation(yaw, pitch, roll).T + pivot
    turned[:, 2] += forward
    p = p + rig.head_weight[:, None] * (turned - p)
    pivot = np.array(rig.torso_pivot)
    p = (p - pivot) @ rotation(0.0, t_pitch, t_roll).T + pivot
    p[:, 2] += t_forward
    posed: FloatArray = p
    return posed


def shape_opacity(shape: Shape, values: FloatArray) -> float:
    value = shape.opacity + sum(weight * float(values[channel]) for channel, weight in shape.opacity_weights)
    return min(1.0, max(0.0, value))


def _clean(text: str) -> str:
    # "-0.00" and "0.00" are the same number; write it one way (face.js does the same).
    text = text.replace(" -0.00", " 0.00")
    return "0.00" + text[5:] if text.startswith("-0.00") else text


def _coordinates(values: FloatArray) -> str:
    """``x y x y …`` with two decimals (one format call for the whole row)."""
    flat = values.reshape(-1)
    return _clean(("%.2f " * len(flat))[:-1] % tuple(flat.tolist()))


def curve_path(points: FloatArray, closed: bool, corners: Sequence[bool]) -> str:
    """``M … C …`` through ``points`` (Catmull-Rom tangents; a corner or an open end uses
    the one-sided difference, so the curve turns sharply there)."""
    count = len(points)
    if count == 1:
        return f"M {_coordinates(points[0])}"
    prev = np.roll(points, 1, axis=0)
    nxt = np.roll(points, -1, axis=0)
    incoming = points - prev
    outgoing = nxt - points
    if not closed:  # an open end has one neighbour: both tangents point along it
        incoming[0] = outgoing[0]
        outgoing[-1] = incoming[-1]
    smooth = np.array([not corner for corner in corners])
    if not closed:
        smooth[0] = smooth[-1] = False
    central = (nxt - prev) / 2.0
    incoming[smooth] = central[smooth]
    outgoing[smooth] = central[smooth]
    segments = count if closed else count - 1
    starts = np.arange(segments)
    ends = (starts + 1) % count
    rows = np.concatenate(
        [points[starts] + outgoing[starts] / 3.0, points[ends] - incoming[ends] / 3.0, points[ends]], axis=1
    )
    body = _coordinates(rows).split(" ")
    parts = [f"M {_coordinates(points[0])}"]
    for index in range(segments):
        parts.append("C " + " ".join(body[6 * index : 6 * index + 6]))
    if closed:
        parts.append("Z")
    return " ".join(parts)


def ellipse_path(centre: FloatArray, x_axis: FloatArray, y_axis: FloatArray) -> str:
    a = x_axis - centre
    b = y_axis - centre
    quarters = [(a, b), (b, -a), (-a, -b), (-b, a)]
    rows = np.array(
        [np.concatenate([centre + u + _KAPPA * v, centre + v + _KAPPA * u, centre + v]) for u, v in quarters]
    )
    body = _coordinates(rows).split(" ")
    parts = [f"M {_coordinates(centre + a)}"]
    for index in range(4):
        parts.append("C " + " ".join(body[6 * index : 6 * index + 6]))
    parts.append("Z")
    return " ".join(parts)


def shape_paths(rig: Rig, screen: FloatArray, values: FloatArray) -> list[tuple[str, float]]:
    """``(path data, opacity)`` per shape, in drawing order; invisible shapes get ``""``."""
    result: list[tuple[str, float]] = []
    for shape in rig.shapes:
        alpha = shape_opacity(shape, values)
        if alpha <= 0.0:
            result.append(("", 0.0))
            continue
        members = screen[list(shape.points)]
        if shape.kind == "ellipse":
            path = ellipse_path(members[0], members[1], members[2])
        else:
            path = curve_path(members, shape.closed, shape.corners)
        result.append((path, alpha))
    return result

"""The face in video frames: the rig's path data drawn with aggdraw (anti-aliased AGG).

The page draws the very same path strings as SVG ``<path d=…>`` (see ``face.js``); here
they go to :class:`aggdraw.Symbol`, which reads SVG path syntax.  aggdraw strokes use
butt caps and miter joins, which are also SVG's defaults, so the two drawings agree.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from mse.export.face.rig import FloatArray, Rig, pose_model, project, shape_paths
from mse.extras import require

if TYPE_CHECKING:
    from PIL import Image

    from mse.export.face.body import HalfBody

#: Arms given from outside (motion): ``[side, (elbow, wrist), xyz]`` offsets from the shoulder.
ArmOffsets = FloatArray


def face_scale(rig: Rig, size: tuple[int, int]) -> tuple[float, float, float]:
    """``(scale, dx, dy)`` that fits the rig's view box in ``size``, centred."""
    width, height = size
    scale = min(width / rig.view_box[0], height / rig.view_box[1])
    return scale, (width - scale * rig.view_box[0]) / 2.0, (height - scale * rig.view_box[1]) / 2.0


def face_image(
    rig: Rig,
    values: FloatArray,
    size: tuple[int, int],
    body: HalfBody | None = None,
    arms: ArmOffsets | None = None,
) -> Image.Image:
    """A new RGB image of ``size`` with the face for channel ``values`` (with ``body``: the
    half-body view, arms from ``arms`` when given, else from the hand-place channels)."""
    with require("video"):
        from PIL import Image

    image = Image.new("RGB", size, rig.background)
    draw_face(image, rig, values, (0, 0, size[0], size[1]), body, arms)
    return image


def draw_face(
    image: Image.Image,
    rig: Rig,
    values: FloatArray,
    box: tuple[int, int, int, int],
    body: HalfBody | None = None,
    arms: ArmOffsets | None = None,
) -> None:
    """Draw the face for channel ``values`` into ``box`` (left, top, right, bottom) of ``image``.

    aggdraw copies the whole image in and out: draw into a small image (:func:`face_image`)
    and paste it when the frame is large."""
    with require("video"):
        import aggdraw

    if body is not None:
        rig = body.rig
    left, top, right, bottom = box
    scale, dx, dy = face_scale(rig, (right - left, bottom - top))
    offset = np.array([left + dx, top + dy])
    model = pose_model(rig, values)
    screen = project(rig, model) * scale + offset
    canvas = aggdraw.Draw(image)
    canvas.rectangle(box, aggdraw.Brush(rig.background))
    for shape, (path, alpha) in zip(rig.shapes, shape_paths(rig, screen, values), strict=True):
        if not path:
            continue
        level = round(255 * alpha)
        pen = aggdraw.Pen(shape.stroke, shape.width * scale, level) if shape.stroke and shape.width > 0 else None
        brush = aggdraw.Brush(shape.fill, level) if shape.fill else None
        symbol = aggdraw.Symbol(path)
        if pen is not None and brush is not None:
            canvas.symbol((0, 0), symbol, pen, brush)
        elif brush is not None:
            canvas.symbol((0, 0), symbol, brush)
        elif pen is not None:
            canvas.symbol((0, 0), symbol, pen)
    if body is not None:
        from mse.export.face.body import arm_joints, draw_arms

        joints = arm_joints(body, model, values)
        if arms is not None:
            joints = [(s, s + arms[side, 0], s + arms[side, 1]) for side, (s, _, _) in enumerate(joints)]
        draw_arms(canvas, body, joints, lambda points: project(rig, points) * scale + offset, scale)
    canvas.flush()

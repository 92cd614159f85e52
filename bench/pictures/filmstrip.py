"""Filmstrips: a few frames of clips as stick figures in one small PNG (Pillow).

``filmstrip(rows, path)`` draws one row per (label, motion): ``frames`` frames spread evenly
over each clip, each clip turned to its own body frame (facing +Z) and seen from its right
side and a little in front (``yaw`` degrees round the vertical axis, 65 by default, so that
bows and leans show), all rows on one scale so that heights compare. Used by the benches to put real and
generated clips side by side in ``docs/images``.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from bench.evaluation.fidelity import body_of
from mse.export.figures import project
from mse.motion.base.bvh import Motion

CELL = (140, 200)  # pixels per frame
MARGIN = 8


def filmstrip(rows: Sequence[tuple[str, Motion]], path: str | Path, frames: int = 6, yaw: float = 65.0) -> None:
    """Write a PNG with one row of ``frames`` stick figures per (label, motion)."""
    from PIL import Image, ImageDraw

    projected = []
    hidden = []  # joints above the hips (Bandai's joint_Root stays at the origin): not drawn
    for _, motion in rows:
        body = body_of(motion)
        positions = body.positions
        picks = np.linspace(0, motion.frame_count - 1, frames).round().astype(int)
        points = project(positions[picks], yaw)  # (frames, J, 2)
        hips = motion.skeleton.parents[body.body.left_hip]
        above = set()
        joint = motion.skeleton.parents[hips]
        while joint >= 0:
            above.add(joint)
            joint = motion.skeleton.parents[joint]
        # each frame centred on its own hips so that travelling clips stay in the cell
        points[..., 0] -= points[:, hips : hips + 1, 0]
        points[:, sorted(above)] = points[:, hips : hips + 1]
        projected.append(points)
        hidden.append(above)
    heights = [float(np.ptp(p[..., 1])) for p in projected]
    widths = [float(np.ptp(p[..., 0])) for p in projected]
    scale = min((CELL[1] - 2 * MARGIN) / max(max(heights), 1e-6), (CELL[0] - 2 * MARGIN) / max(max(widths), 1e-6))
    label_width = 150
    image = Image.new("RGB", (label_width + CELL[0] * frames, CELL[1] * len(rows)), "white")
    draw = ImageDraw.Draw(image)
    floor = min(float(p[..., 1].min()) for p in projected)
    for row, ((label, motion), points) in enumerate(zip(rows, projected, strict=True)):
        top = row * CELL[1]
        draw.text((6, top + CELL[1] // 2 - 6), label, fill=(40, 40, 40))
        parents = motion.skeleton.parents
        for column in range(frames):
            left = label_width + column * CELL[0]
            centre = left + CELL[0] / 2

            def to_pixel(point: np.ndarray, centre: float = centre, top: int = top) -> tuple[float, float]:
                return (centre + point[0] * scale, top + CELL[1] - MARGIN - (point[1] - floor) * scale)

            frame = points[column]
            for joint, parent in enumerate(parents):
                if parent < 0 or parent in hidden[row]:
                    continue
                draw.line([to_pixel(frame[parent]), to_pixel(frame[joint])], fill=(38, 50, 56), width=2)
            for joint in range(len(parents)):
                if joint in hidden[row]:
                    continue
                x, y = to_pixel(frame[joint])
                draw.ellipse([x - 1.5, y - 1.5, x + 1.5, y + 1.5], fill=(224, 122, 95))
            ground = top + CELL[1] - MARGIN
            draw.line([(left + 4, ground), (left + CELL[0] - 4, ground)], fill=(200, 200, 200))
        if row:
            draw.line([(0, top), (image.width, top)], fill=(220, 220, 220))
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    image.save(path, optimize=True)


#: colours of the rows' paths in :func:`top_view`
PATH_COLOURS = ((38, 50, 56), (224, 122, 95), (61, 133, 198), (106, 168, 79), (153, 102, 204))


def top_view(rows: Sequence[tuple[str, Motion]], path: str | Path, size: int = 420) -> None:
    """Write a PNG of the hips' paths seen from above (X right, Z up), one colour per
    (label, motion), all on one scale, each starting at the centre (a dot marks the start, a
    tick every second): a turning walk's arc, and where it stops or goes back."""
    from PIL import Image, ImageDraw

    tracks = []
    for _, motion in rows:
        body = body_of(motion)
        hips = 0.5 * (motion.positions()[:, body.body.left_hip] + motion.positions()[:, body.body.right_hip])
        tracks.append(hips[:, [0, 2]] - hips[:1, [0, 2]])
    reach = max(max(float(np.abs(t).max()) for t in tracks), 1e-6)
    label_height = 16 * len(rows) + 8
    image = Image.new("RGB", (size, size + label_height), "white")
    draw = ImageDraw.Draw(image)
    scale = (size / 2 - 2 * MARGIN) / reach
    # the first rows drawn last, on top (a clip at twice the length covers its start)
    for k, ((label, motion), track) in reversed(list(enumerate(zip(rows, tracks, strict=True)))):
        colour = PATH_COLOURS[k % len(PATH_COLOURS)]
        pixels = [(size / 2 + x * scale, size / 2 - z * scale) for x, z in track]
        draw.line(pixels, fill=colour, width=2)
        draw.ellipse([pixels[0][0] - 4, pixels[0][1] - 4, pixels[0][0] + 4, pixels[0][1] + 4], fill=colour)
        every = max(1, round(1.0 / motion.frame_time))
        for x, y in pixels[every::every]:
            draw.ellipse([x - 1.5, y - 1.5, x + 1.5, y + 1.5], fill=colour)
        draw.text((8, size + 4 + 16 * k), label, fill=colour)
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    image.save(path, optimize=True)

"""Stick-figure clips for the HTML viewer: joint positions per frame, small enough to embed.

The page gets a JSON object (the format is ours, documented in docs/export.md)::

    {"fps": 30, "bounds": [xmin, ymin, xmax, ymax], "clips": [
      {"signal": "4", "lexeme": "...", "start": 1.2, "stop": 3.4,
       "parents": [-1, 0, 1, ...], "joints": ["Hips", ...],
       "frames": [[x0, y0, x1, y1, ...], ...]}]}

Positions are a three-quarter view (35° yaw; y up; BVH units, rounded to 0.1) resampled at
``fps``.
The player shows **one body**: when the timeline was animated (``extra["animation"]
["timeline_bvh"]``, the whole timeline composed by body part) that file is the only clip
(``signal`` ``"timeline"``), so overlapping leaves are seen together and never one clip hiding
another; timelines without it (older outputs) get one clip per signal's BVH
(``signal.motion["file"]``). Files are read through :mod:`mse.motion.base.bvh`, imported only
when a timeline has motion.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from mse.timeline import Timeline, TimelineSignal

FloatArray = npt.NDArray[np.float64]
#: Camera yaw of the stick-figure view, degrees round the vertical axis.
VIEW_YAW_DEGREES = 35.0


@dataclass(frozen=True)
class FigureClip:
    """One occurrence's motion: ``positions[frame, joint] = (x, y, z)`` at ``fps``."""

    signal: str
    lexeme: str
    start: float
    stop: float
    fps: float
    joints: tuple[str, ...]
    parents: tuple[int, ...]
    positions: FloatArray


def resample(positions: FloatArray, source_fps: float, target_fps: float) -> FloatArray:
    """Nearest-frame resampling (enough for a preview; no interpolation artefacts)."""
    count = positions.shape[0]
    if count == 0 or source_fps <= 0 or abs(source_fps - target_fps) < 1e-6:
        return positions
    length = (count - 1) / source_fps
    times = np.arange(0.0, length + 1e-9, 1.0 / target_fps)
    indices = np.clip(np.rint(times * source_fps).astype(np.int64), 0, count - 1)
    return positions[indices]


def project(positions: FloatArray, yaw_degrees: float = VIEW_YAW_DEGREES) -> FloatArray:
    """Three-quarter view: turn round the vertical (Y) axis, keep (x', y).

    A pure front view hides bows and leans (they move along Z); turning the camera shows
    both sideways and forward movement.
    """
    angle = np.radians(yaw_degrees)
    x = positions[..., 0] * np.cos(angle) + positions[..., 2] * np.sin(angle)
    return np.stack([x, positions[..., 1]], axis=-1)


def payload(clips: Sequence[FigureClip], fps: int) -> dict[str, Any]:
    """The JSON object the viewer script reads (front view, rounded, shared bounds)."""
    entries: list[dict[str, Any]] = []
    mins: list[FloatArray] = []
    maxs: list[FloatArray] = []
    for clip in clips:
        frames = resample(clip.positions, clip.fps, float(fps))
        # The player holds the last frame past the clip's end; frames after the
        # occurrence's stop are never shown, so they are not embedded.
        frames = frames[: math.ceil((clip.stop - clip.start) * fps) + 1]
        if frames.size == 0:
            continue
        front = np.round(project(frames), 1)
        mins.append(front.reshape(-1, 2).min(axis=0))
        maxs.append(front.reshape(-1, 2).max(axis=0))
        entries.append(
            {
                "signal": clip.signal,
                "lexeme": clip.lexeme,
                "start": round(clip.start, 3),
                "stop": round(clip.stop, 3),
                "joints": list(clip.joints),
                "parents": list(clip.parents),
                "frames": [[float(v) for v in frame.reshape(-1)] for frame in front],
            }
        )
    if not entries:
        return {"fps": fps, "bounds": [0, 0, 1, 1], "clips": []}
    low = np.min(np.stack(mins), axis=0)
    high = np.max(np.stack(maxs), axis=0)
    bounds = [float(low[0]), float(low[1]), float(high[0]), float(high[1])]
    return {"fps": fps, "bounds": bounds, "clips": entries}


def motion_file(signal: TimelineSignal, base_dir: Path | None) -> Path | None:
    """The BVH file of a signal's generated motion, if the timeline names one."""
    if signal.motion is None:
        return None
    name = signal.motion.get("file")
    if not isinstance(name, str) or not name.strip():
        return None
    path = Path(name)
    if path.is_absolute() or base_dir is None:
        return path
    # Relative to the motion folder; a path already relative to the working folder also works.
    inside = base_dir / path
    return path if not inside.exists() and path.exists() else inside


#: the composite clip's caption in the player
COMPOSITE_LABEL = "all motion leaves on one body"


def composite_file(timeline: Timeline, base_dir: Path | None) -> Path | None:
    """The whole-timeline BVH of an animated timeline, if it names one that exists."""
    animation = timeline.extra.get("animation")
    name = animation.get("timeline_bvh") if isinstance(animation, dict) else None
    if not isinstance(name, str) or not name.strip():
        return None
    path = Path(name)
    if not path.is_absolute() and base_dir is not None:
        path = base_dir / path
    return path if path.is_file() else None


def clips_from_timeline(timeline: Timeline, base_dir: Path | None) -> list[FigureClip]:
    """The composite clip of an animated timeline, else every motion file the timeline
    names; bad files raise MseError (E100)."""
    composite = composite_file(timeline, base_dir)
    if composite is not None and any(motion_file(s, base_dir) for s in timeline.signals):
        fps, joints, parents, positions = _read_bvh_positions(composite)
        return [FigureClip("timeline", COMPOSITE_LABEL, 0.0, timeline.duration, fps, joints, parents, positions)]
    clips: list[FigureClip] = []
    for signal in timeline.signals:
        path = motion_file(signal, base_dir)
        if path is None:
            continue
        fps, joints, parents, positions = _read_bvh_positions(path)
        clips.append(FigureClip(signal.id, signal.lexeme, signal.start, signal.stop, fps, joints, parents, positions))
    return clips


def _read_bvh_positions(path: Path) -> tuple[float, tuple[str, ...], tuple[int, ...], FloatArray]:
    """fps, joint names, parent indices and positions ``[frame, joint, xyz]`` in the clip's
    body frame (first-frame hips: X to the body's left, Y up, Z forward), so that every clip
    is seen from the same side whichever way its performer faced."""
    # The motion layer's reader (raises MseError E100 itself), imported only when needed.
    from mse.diagnostics import MseError
    from mse.motion.base.body_frame import body_of
    from mse.motion.base.bvh import read_bvh

    motion = read_bvh(path)
    skeleton = motion.skeleton
    fps = 1.0 / motion.frame_time if motion.frame_time > 0 else 30.0
    try:
        positions = np.asarray(body_of(motion, str(path)).positions, dtype=np.float64)
    except MseError:  # no recognisable hips or hands: as captured
        positions = np.asarray(motion.positions(), dtype=np.float64)
    return fps, tuple(skeleton.names), tuple(skeleton.parents), positions

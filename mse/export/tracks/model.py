"""One track model: a timeline sampled at a frame rate as FACS action units, ARKit
blendshapes, head rotation and gaze angles.

The values are the face player's: :func:`sample` evaluates the face player's track
(:func:`mse.export.face.page.face_track`, the keys the viewer and the videos play) with
:meth:`~mse.export.face.track.Track.values` at the frame times, and reads every curve from
those rig channels, so the tracks and the face player cannot drift apart:

- action unit *n* (0-5) = 5 x the larger of the rig's ``AUn:L`` and ``AUn:R`` (0-1);
- head pitch, yaw, roll (degrees) = the rig's ``head_pitch``, ``head_yaw``, ``head_roll``;
- gaze (degrees) = the rig's ``gaze_x``, ``gaze_y`` (-1..1) x :data:`GAZE_DEGREES`;
- ARKit weights = the sided units through the table of ``arkit.toml`` (:mod:`.arkit`).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from mse.export.face.page import face_track
from mse.export.face.rig import FloatArray, default_rig
from mse.export.options import ExportOptions
from mse.timeline import Timeline

#: Frames per second of every track format (Live Link Face and OpenFace record at 30 fps too).
TRACK_FPS = 30
#: Gaze angle (degrees) of the face player's full gaze (``gaze_x`` or ``gaze_y`` = 1).
GAZE_DEGREES = 25.0
#: FACS intensity scale: 5 is the E ("maximum") level, as OpenFace's AU_r columns.
AU_SCALE = 5.0
_SIDED = re.compile(r"^AU(\d+):([LR])$")


@dataclass(frozen=True)
class Tracks:
    """Curves at ``times`` (seconds, frame k at k / fps).

    ``sides[f, i, s]``: unit ``units[i]`` on side s (0: the agent's left, 1: right), 0-1;
    ``head[f]``: (pitch, yaw, roll) degrees (pitch > 0 down, yaw > 0 to the agent's left,
    roll > 0 to the agent's left); ``gaze[f]``: (x, y) degrees (x > 0 the agent's left, y > 0 down).
    """

    fps: float
    times: FloatArray
    units: tuple[int, ...]
    sides: FloatArray
    head: FloatArray
    gaze: FloatArray

    @property
    def frame_count(self) -> int:
        return len(self.times)

    @property
    def au(self) -> FloatArray:
        """FACS intensities 0-5 ``[frames, units]``: the stronger side."""
        result: FloatArray = AU_SCALE * self.sides.max(axis=2)
        return result

    def unit(self, number: int) -> FloatArray:
        """One unit's intensity 0-5 over the frames (zeros for units the face does not drive)."""
        if number not in self.units:
            return np.zeros(self.frame_count)
        result: FloatArray = self.au[:, self.units.index(number)]
        return result


def frame_times(duration: float, fps: float) -> FloatArray:
    """k / fps for every frame from 0 to the timeline's end (inclusive)."""
    count = math.floor(max(duration, 0.0) * fps + 1e-9) + 1
    times: FloatArray = np.arange(count, dtype=np.float64) / fps
    return times


def sample(timeline: Timeline, options: ExportOptions = ExportOptions(), fps: float = TRACK_FPS) -> Tracks:
    """The timeline's curves at ``fps`` (see the module docstring)."""
    rig = default_rig()
    track = face_track(timeline, options, rig)
    times = frame_times(timeline.duration, fps)
    values = track.values(times)
    index = rig.channel_index
    units = sorted({int(m.group(1)) for name in rig.channels if (m := _SIDED.match(name))})
    sides = np.zeros((len(times), len(units), 2))
    for i, number in enumerate(units):
        for s, side in enumerate(("L", "R")):
            channel = index.get(f"AU{number}:{side}")
            if channel is not None:
                sides[:, i, s] = values[:, channel]
    head = values[:, [index["head_pitch"], index["head_yaw"], index["head_roll"]]]
    gaze = np.clip(values[:, [index["gaze_x"], index["gaze_y"]]], -1.0, 1.0) * GAZE_DEGREES
    return Tracks(float(fps), times, tuple(units), sides, head, gaze)

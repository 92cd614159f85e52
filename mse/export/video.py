"""Timelines as video: MP4 (H.264), WebM (VP9), GIF, or a folder of PNG frames.

Frames come from :class:`mse.export.face.frames.FramePainter` (face, body, timeline strip
and playhead); MP4, WebM and GIF are encoded with PyAV (frame by frame), PNG with Pillow.  Frame ``i``
shows time ``i / fps``; a ``d`` s timeline gives ``round(d * fps)`` frames.  Output is
written to a temporary file (or folder) beside the target and renamed at the end, so a
reader never sees half a video and a failed render replaces nothing.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mse import progress
from mse.diagnostics import Diagnostic, MseError, Span, argument_error
from mse.export.face.body import VIEWS
from mse.export.options import ExportOptions
from mse.extras import require
from mse.fileio import atomic_path, staged_folder
from mse.timeline import Timeline

if TYPE_CHECKING:
    from PIL import Image

    from mse.export.face.frames import FramePainter
    from mse.export.figures import FigureClip

#: Video formats and the file suffix of each.
#: Smallest frame that holds the face, the list and the strip (below 40 px of height the
#: strip's lanes have no room).
MIN_WIDTH, MIN_HEIGHT = 64, 48
VIDEO_FORMATS: dict[str, str] = {"mp4": ".mp4", "webm": ".webm", "gif": ".gif"}
MAX_FRAMES = 100_000
MAX_PIXELS = 3840 * 2160


#: The view a render draws unless told otherwise (``--view``; :data:`VIEWS`).
DEFAULT_VIEW = "half-body"


@dataclass(frozen=True)
class VideoOptions:
    """Frame size in pixels (even numbers for MP4/WebM), frame rate, whether to draw the strip
    and the title (with the clock and the list of what plays), and the view: ``half-body``
    (face, torso, arms and hands) or ``face`` (face and bust; motion on a stick figure beside)."""

    size: tuple[int, int] = (960, 540)
    fps: float = 25.0
    strip: bool = True
    quality: int = 20  # H.264 CRF (lower is better); VP9 uses quality + 12
    view: str = DEFAULT_VIEW
    title: bool = True


@dataclass(frozen=True)
class RenderReport:
    """What a render made: frame count and the notes to show once (unmapped lexemes...)."""

    frames: int
    fps: float
    notes: tuple[str, ...] = field(default_factory=tuple)


def _error(code: str, message: str, where: str) -> MseError:
    return MseError([Diagnostic(code, message, Span(where))])


def check_options(video: VideoOptions, fmt: str | None = None) -> None:
    width, height = video.size
    if not (MIN_WIDTH <= width <= 7680 and MIN_HEIGHT <= height <= 4320) or width * height > MAX_PIXELS:
        smallest = f"{MIN_WIDTH}x{MIN_HEIGHT}"
        raise argument_error(f"frame size {width}x{height} must be between {smallest} and 3840x2160 pixels")
    if fmt in ("mp4", "webm") and (width % 2 or height % 2):
        raise argument_error(f"{fmt} needs an even frame size (got {width}x{height})")
    if not 1.0 <= video.fps <= 120.0:
        raise argument_error(f"frame rate {video.fps:g} must be between 1 and 120")
    if video.view not in VIEWS:
        raise argument_error(f"unknown view {video.view!r} (known: {', '.join(VIEWS)})")


def frame_times(duration: float, fps: float) -> np.ndarray:
    """The time shown by each frame: ``i / fps`` for ``i < round(duration * fps)``."""
    count = max(1, round(duration * fps))
    if count > MAX_FRAMES:
        raise argument_error(f"{count} frames is too many (at most {MAX_FRAMES}); lower --fps")
    return np.arange(count) / fps


def painter(
    timeline: Timeline,
    options: ExportOptions,
    video: VideoOptions,
    clips: Sequence[FigureClip] | None = None,
) -> FramePainter:
    """The frame painter for a timeline (reads the lexeme sources and motion files)."""
    from mse.export import figures
    from mse.export.face.frames import FramePainter
    from mse.export.face.page import face_track

    track = face_track(timeline, options)
    if clips is None:
        clips = figures.clips_from_timeline(timeline, options.motion_base_dir)
    return FramePainter(
        timeline, track, video.size, clips=clips, options=options, strip=video.strip, view=video.view, title=video.title
    )


def iter_frames(frames: FramePainter, times: np.ndarray) -> Iterator[Image.Image]:
    values = frames.track.values(times)
    for index, time in progress.each(list(enumerate(times)), "render", unit="frame"):
        yield frames.paint(float(time), values[index])


def write_video(
    timeline: Timeline,
    path: Path,
    fmt: str,
    options: ExportOptions = ExportOptions(),
    video: VideoOptions = VideoOptions(),
    clips: Sequence[FigureClip] | None = None,
) -> RenderReport:
    """Render ``timeline`` to ``path`` as ``fmt`` (mp4, webm, gif)."""
    if fmt not in VIDEO_FORMATS:
        raise argument_error(f"unknown video format {fmt!r} (known: {', '.join(VIDEO_FORMATS)})")
    check_options(video, fmt)
    times = frame_times(timeline.duration, video.fps)
    frames = painter(timeline, options, video, clips)
    # mse.fileio: the one writer (atomic, mode kept, devices written through, no stray file)
    with atomic_path(path, suffix=VIDEO_FORMATS[fmt]) as temporary:
        if fmt == "gif":
            samples = [frames.paint(float(t)) for t in times[:: max(1, len(times) // 6)]]
            _write_gif(iter_frames(frames, times), temporary, video.fps, samples)
        else:
            _encode(iter_frames(frames, times), temporary, fmt, video)
    return RenderReport(len(times), video.fps, frames.track.notes)


def write_frames(
    timeline: Timeline,
    folder: Path,
    options: ExportOptions = ExportOptions(),
    video: VideoOptions = VideoOptions(),
    clips: Sequence[FigureClip] | None = None,
) -> RenderReport:
    """PNG frames ``frame_00001.png``... into ``folder`` (which must be new or empty)."""
    check_options(video)
    target = Path(folder)
    if target.exists() and (not target.is_dir() or any(target.iterdir())):
        raise _error("E100", "--frames needs a new or empty folder (nothing is overwritten)", str(target))
    times = frame_times(timeline.duration, video.fps)
    frames = painter(timeline, options, video, clips)
    with staged_folder(target) as staging:  # every frame, or none (mse.fileio)
        digits = max(5, len(str(len(times))))
        for index, image in enumerate(iter_frames(frames, times), start=1):
            image.save(staging / f"frame_{index:0{digits}d}.png", compress_level=1)
    return RenderReport(len(times), video.fps, frames.track.notes)


def render_still(
    timeline: Timeline,
    time: float,
    options: ExportOptions = ExportOptions(),
    video: VideoOptions = VideoOptions(),
    clips: Sequence[FigureClip] | None = None,
) -> tuple[Image.Image, RenderReport]:
    """One frame at ``time`` (seconds)."""
    check_options(video)
    frames = painter(timeline, options, video, clips)
    return frames.paint(min(max(time, 0.0), timeline.duration)), RenderReport(1, video.fps, frames.track.notes)


def _encode(images: Iterator[Image.Image], path: Path, fmt: str, video: VideoOptions) -> None:
    with require("video"):
        import av

    rate = Fraction(video.fps).limit_denominator(1001)
    # WebM: bitexact muxing (no random segment id, no date), so a render is reproducible byte for byte
    muxer = {} if fmt == "mp4" else {"fflags": "+bitexact"}
    with av.open(str(path), mode="w", format="mp4" if fmt == "mp4" else "webm", options=muxer) as container:
        if fmt == "mp4":
            stream = container.add_stream("libx264", rate=rate)
            stream.options = {"crf": str(video.quality), "preset": "veryfast", "tune": "animation"}
        else:
            stream = container.add_stream("libvpx-vp9", rate=rate)
            stream.options = {
                "crf": str(video.quality + 12),
                "b:v": "0",
                "deadline": "realtime",
                "cpu-used": "8",
                "row-mt": "1",
            }
        stream.width, stream.height = video.size
        stream.pix_fmt = "yuv420p"
        for image in images:
            frame = av.VideoFrame.from_image(image)  # type: ignore[no-untyped-call]
            for packet in stream.encode(frame):
                container.mux(packet)
        for packet in stream.encode(None):
            container.mux(packet)


def _write_gif(images: Iterator[Image.Image], path: Path, fps: float, samples: Sequence[Image.Image]) -> None:
    """One palette for the whole clip (from sample frames), no dithering: small and stable.

    Encoded with PyAV one frame at a time (Pillow's GIF writer keeps every frame until the
    end), so memory does not grow with the length of the clip."""
    with require("video"):
        import av
        from PIL import Image

    width, height = samples[0].size
    sheet = Image.new("RGB", (width, height * len(samples)))
    for index, sample in enumerate(samples):
        sheet.paste(sample, (0, index * height))
    palette = sheet.quantize(colors=255, method=Image.Quantize.MEDIANCUT)
    colours = np.zeros((256, 4), dtype=np.uint8)  # ARGB entries, opaque
    colours[:, 0] = 255
    rgb = np.asarray(palette.getpalette() or [], dtype=np.uint8).reshape(-1, 3)[:256]
    colours[: len(rgb), 1:] = rgb
    with av.open(str(path), mode="w", format="gif") as container:
        stream = container.add_stream("gif", rate=Fraction(fps).limit_denominator(1001))
        stream.width, stream.height = width, height
        stream.pix_fmt = "pal8"
        for image in images:
            indices = np.asarray(image.quantize(palette=palette, dither=Image.Dither.NONE), dtype=np.uint8)
            frame = av.VideoFrame.from_ndarray((indices, colours), format="pal8")  # type: ignore[arg-type]  # pal8 takes (indices, palette)
            for packet in stream.encode(frame):
                container.mux(packet)
        for packet in stream.encode(None):
            container.mux(packet)


def render_stimulus(
    timeline: Timeline,
    out_path: Path,
    *,
    view: str = DEFAULT_VIEW,
    title: bool = False,
    strip: bool = False,
    size: tuple[int, int] = (640, 720),
    fps: float = 25.0,
    still_at: float | None = None,
    options: ExportOptions = ExportOptions(),
) -> RenderReport:
    """One stimulus of a perception study: ``timeline`` as a video (``.mp4``, ``.webm``,
    ``.gif``) or, with ``still_at`` (seconds), as one PNG frame at that time; by default
    without title, clock, lists or strip (nothing on the frame but the agent).  The same
    timeline and arguments give the same frames (deterministic)."""
    from mse.fileio import write_atomic

    video = VideoOptions(size=size, fps=fps, strip=strip, view=view, title=title)
    suffix = Path(out_path).suffix.lower()
    if (still_at is not None) != (suffix == ".png"):
        raise argument_error(f"{out_path}: a still (still_at) is a .png, a video is .mp4, .webm or .gif")
    if still_at is not None:
        import io

        image, report = render_still(timeline, still_at, options, video)
        buffer = io.BytesIO()
        image.save(buffer, format="PNG")
        write_atomic(Path(out_path), buffer.getvalue())
        return report
    fmt = Path(out_path).suffix.lower().lstrip(".")
    return write_video(timeline, Path(out_path), fmt, options, video)

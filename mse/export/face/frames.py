"""Video frames: the face (and the body, when the timeline has motion) above the timeline
strip with its playhead.

The strip is drawn once from the SVG exporter's layout (:func:`mse.export.svg.layout`: the
same lanes, bars and labels) and cropped per frame; a timeline wider than the frame scrolls
so that the playhead stays in view.  The face is :func:`mse.export.face.raster.face_image`
(redrawn only when its channels change); the body is the stick figure of
:func:`mse.export.figures.payload` (the viewer's player).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from mse.export.bml import provenance
from mse.export.face.raster import face_image
from mse.export.face.rig import Rig, default_rig
from mse.export.face.track import Track, key_weight
from mse.export.options import ExportOptions
from mse.export.svg import BAR_HEIGHT, LANE_COLOURS, OTHER_COLOUR, Layout, layout
from mse.extras import require
from mse.timeline import Timeline

if TYPE_CHECKING:
    from PIL import Image, ImageDraw, ImageFont

    from mse.export.figures import FigureClip

BACKGROUND = "#ffffff"
HEADER_HEIGHT = 26
STRIP_SHARE = 0.36  # at most this share of the frame height goes to the strip
MIN_STRIP_ZOOM = 0.2  # smallest scale of the strip; rows below what fits are not drawn
MAX_STRIP_WIDTH = 20_000  # drawing pixels (the SVG layout's widest is 16,000 within the duration)
PLAYHEAD = "#d62828"


@dataclass(frozen=True)
class FrameLayout:
    size: tuple[int, int]
    face_box: tuple[int, int, int, int]
    body_box: tuple[int, int, int, int] | None
    info_box: tuple[int, int, int, int] | None
    strip_box: tuple[int, int, int, int]


def _font(size: int) -> ImageFont.FreeTypeFont | ImageFont.ImageFont:
    with require("video"):
        from PIL import ImageFont

    try:  # the viewer's font when the system has it ...
        return ImageFont.truetype("DejaVuSans.ttf", size)
    except OSError:  # ... else Pillow's own scalable font
        return ImageFont.load_default(size)


def _text(font: object, text: str) -> str:
    """``text`` as it can be drawn: control and format characters (U+0085, U+2028...) make
    Pillow's text layout fail, so they show as "?"; Pillow's fallback font has no em dash."""
    import unicodedata

    if not text.isprintable():
        text = "".join(c if c == " " or unicodedata.category(c)[0] not in "CZ" else "?" for c in text)
    return text if "DejaVu" in str(getattr(font, "path", "")) else text.replace("—", "-")


def frame_layout(size: tuple[int, int], strip_height: int, with_body: bool, face_aspect: float) -> FrameLayout:
    """Columns above the strip: the face, the body (with motion), then the list of what is
    playing when there is room for it."""
    width, height = size
    strip_top = height - strip_height
    top = HEADER_HEIGHT
    panel = strip_top - top
    face_width = min(width if not with_body else width // 2, round(panel * face_aspect) + 24)
    body_width = min(width - face_width, panel) if with_body else 0
    rest = width - face_width - body_width
    if rest < 220:  # no room for the list: the pictures share the width
        face_width += rest if not with_body else rest // 2
        body_width = width - face_width if with_body else 0
        rest = 0
    face = (0, top, face_width, strip_top)
    body = (face_width, top, face_width + body_width, strip_top) if with_body else None
    info = (width - rest, top, width, strip_top) if rest else None
    return FrameLayout(size, face, body, info, (0, strip_top, width, height))


class StripPainter:
    """The timeline strip: drawn once at the layout's scale, then cropped per frame."""

    def __init__(self, timeline: Timeline, width: int, max_height: int) -> None:
        with require("video"):
            from PIL import Image, ImageDraw

        self.timeline = timeline
        self.geometry: Layout = layout(timeline, title=False)
        g = self.geometry
        # Never shrunk below MIN_STRIP_ZOOM: the rows that do not fit at that scale are left
        # out, so the drawing (and memory) stays bounded however many rows the timeline has.
        self.zoom = max(min(1.0, max_height / g.height), MIN_STRIP_ZOOM)
        drawn_height = min(g.height, math.ceil(max_height / self.zoom))
        # The visible part of the drawing, in drawing pixels: lane names stay, time scrolls.
        self.view_width = width / self.zoom
        # Bars past the timeline's end (a signal that starts after it) widen the drawing
        # without bound: what lies beyond MAX_STRIP_WIDTH is not drawn.
        self.drawn_width = min(max(g.width, math.ceil(self.view_width)), MAX_STRIP_WIDTH)
        image = Image.new("RGB", (self.drawn_width, drawn_height), BACKGROUND)
        draw = ImageDraw.Draw(image)
        small, bold = _font(10), _font(12)
        for index, lane in enumerate(g.lanes):
            if lane.y >= drawn_height:
                break
            fill = "#eeeeee" if index % 2 else "#f7f7f7"
            draw.rectangle((0, lane.y, g.width, lane.y + lane.height), fill=fill)
            modality = _text(bold, lane.modality)
            draw.text((10, lane.y + lane.height / 2), modality, fill="#222222", font=bold, anchor="lm")
        count = math.floor(timeline.duration / g.tick_step + 1e-9)
        for index in range(count + 1):
            t = index * g.tick_step
            x = g.x0 + t * g.scale
            draw.line((x, g.top - 6, x, drawn_height - 8), fill="#dddddd")
            draw.text((x, g.top - 10), f"{round(t, 3):g} s", fill="#555555", font=small, anchor="ms")
        self.bars = []
        label_font = _font(11)
        for bar in g.bars:
            if bar.y >= drawn_height:
                continue
            colour = LANE_COLOURS.get(bar.behaviour.modality, OTHER_COLOUR)
            box = (bar.x, bar.y, bar.x + bar.width, bar.y + BAR_HEIGHT)
            draw.rounded_rectangle(box, radius=4, fill=colour, outline="#333333")
            if bar.label:
                x = bar.x + 4 if bar.label_inside else bar.x + bar.width + 3
                draw.text((x, bar.y + BAR_HEIGHT / 2), _text(label_font, bar.label), fill="#111111", font=label_font,
                          anchor="lm")
            self.bars.append((bar.behaviour.signal.start, bar.behaviour.signal.stop, box))
        self.width = width
        self.drawn_height = drawn_height
        self.height = math.ceil(drawn_height * self.zoom)
        # Zoomed once here; per frame only crops, outlines and the playhead.
        self.image = image.resize((round(image.width * self.zoom), self.height), resample=_lanczos())

    def paint(self, frame: Image.Image, top: int, time: float) -> None:
        """Paste the visible part at ``top``, outline the active bars, draw the playhead."""
        with require("video"):
            from PIL import ImageDraw

        g = self.geometry
        z = self.zoom
        offset = 0.0  # in drawing pixels
        if self.drawn_width > self.view_width:
            wanted = time * g.scale - 0.35 * (self.view_width - g.x0)
            offset = min(max(0.0, wanted), self.drawn_width - self.view_width)
        left = round(offset * z)
        frame.paste(self.image.crop((left, 0, left + self.width, self.height)), (0, top))
        if offset > 0:
            frame.paste(self.image.crop((0, 0, round(g.x0 * z), self.height)), (0, top))
        draw = ImageDraw.Draw(frame)
        floor = g.x0 if offset > 0 else 0.0
        for start, stop, (x1, y1, x2, y2) in self.bars:
            if start <= time < stop:
                a, b = max(x1 - offset, floor), x2 - offset
                if b > a:
                    box = (a * z, top + y1 * z, b * z, top + y2 * z)
                    draw.rounded_rectangle(box, radius=4 * z, outline="#000000", width=2)
        x = (g.x0 + time * g.scale - offset) * z
        draw.line((x, top + (g.top - 6) * z, x, top + (self.drawn_height - 8) * z), fill=PLAYHEAD, width=2)


def _lanczos() -> Any:
    with require("video"):
        from PIL import Image

    return Image.Resampling.LANCZOS


class BodyPainter:
    """The stick figure of the viewer, from :func:`mse.export.figures.payload`."""

    def __init__(self, clips: Sequence[FigureClip], fps: int) -> None:
        from mse.export.figures import payload

        self.data = payload(clips, fps)

    def paint(self, frame: Image.Image, box: tuple[int, int, int, int], time: float) -> str:
        with require("video"):
            import aggdraw

        data = self.data
        clips = data["clips"]
        active = -1
        for index, clip in enumerate(clips):
            if clip["start"] <= time < clip["stop"]:
                active = index
        clip = clips[max(active, 0)]
        frame_index = 0
        if active >= 0:
            frame_index = min(len(clip["frames"]) - 1, math.floor((time - clip["start"]) * data["fps"]))
        left, top, right, bottom = box
        x_min, y_min, x_max, y_max = data["bounds"]
        margin = 16
        span = max(x_max - x_min, y_max - y_min, 1e-6)
        scale = (min(right - left, bottom - top) - 2 * margin) / span
        ox = left + (right - left - (x_max - x_min) * scale) / 2
        oy = (bottom - top - (y_max - y_min) * scale) / 2
        points = clip["frames"][frame_index]

        def px(index: int) -> tuple[float, float]:
            return ox + (points[2 * index] - x_min) * scale, bottom - (oy + (points[2 * index + 1] - y_min) * scale)

        canvas = aggdraw.Draw(frame)
        canvas.rectangle(box, aggdraw.Brush("#fbfbfb"))
        pen = aggdraw.Pen("#263238" if active >= 0 else "#b0bec5", 3)
        for joint, parent in enumerate(clip["parents"]):
            if parent >= 0:
                canvas.line((*px(parent), *px(joint)), pen)
        brush = aggdraw.Brush("#e07a5f" if active >= 0 else "#cfd8dc")
        for joint in range(len(clip["parents"])):
            x, y = px(joint)
            canvas.ellipse((x - 3, y - 3, x + 3, y + 3), brush)
        canvas.flush()
        return f"{clip['lexeme']} ({clip['signal']})" if active >= 0 else ""


class FramePainter:
    """Every frame of one timeline: ``paint(time)`` returns an RGB image of ``size``."""

    def __init__(
        self,
        timeline: Timeline,
        track: Track,
        size: tuple[int, int],
        *,
        clips: Sequence[FigureClip] = (),
        options: ExportOptions = ExportOptions(),
        rig: Rig | None = None,
        strip: bool = True,
    ) -> None:
        with require("video"):
            from PIL import Image, ImageDraw

        self.timeline = timeline
        self.track = track
        self.rig = rig or default_rig()
        width, height = size
        self.strip = StripPainter(timeline, width, round(height * STRIP_SHARE)) if strip else None
        strip_height = self.strip.height if self.strip else 0
        self.body = BodyPainter(clips, options.figure_fps) if clips else None
        aspect = self.rig.view_box[0] / self.rig.view_box[1]
        self.layout = frame_layout(size, strip_height, self.body is not None, aspect)
        base = Image.new("RGB", size, BACKGROUND)
        draw = ImageDraw.Draw(base)
        draw.rectangle(self.layout.face_box, fill=self.rig.background)
        title = options.title or provenance(timeline)
        font = _font(14)
        draw.text((10, HEADER_HEIGHT / 2), _text(font, title), fill="#222222", font=font, anchor="lm")
        self.base = base
        self.small = _font(12)
        self.clock_font = _font(14)
        left, top, right, bottom = self.layout.face_box
        scale = min((right - left) / self.rig.view_box[0], (bottom - top) / self.rig.view_box[1])
        self.face_size = (max(1, round(scale * self.rig.view_box[0])), max(1, round(scale * self.rig.view_box[1])))
        self.face_at = (left + (right - left - self.face_size[0]) // 2, top + (bottom - top - self.face_size[1]) // 2)
        self._last: tuple[np.ndarray, Image.Image] | None = None

    def paint(self, time: float, values: np.ndarray | None = None) -> Image.Image:
        with require("video"):
            from PIL import ImageDraw

        frame = self.base.copy()
        if values is None:
            values = self.track.values(np.array([time]))[0]
        if self._last is None or not np.array_equal(self._last[0], values):
            self._last = (values.copy(), face_image(self.rig, values, self.face_size))
        frame.paste(self._last[1], self.face_at)
        draw = ImageDraw.Draw(frame)
        if self.layout.info_box is not None:
            self._playing(draw, self.layout.info_box, time)
        else:
            left, top, _, _ = self.layout.face_box
            for line, marker in enumerate(self.track.active_markers(time)):
                draw.text(
                    (left + 8, top + 8 + 16 * line),
                    _text(self.small, f"• {marker.label}"),
                    fill="#8a3b12",
                    font=self.small,
                )
        if self.body is not None and self.layout.body_box is not None:
            caption = self.body.paint(frame, self.layout.body_box, time)
            if caption:
                bl, _, _, bb = self.layout.body_box
                draw.text((bl + 8, bb - 8), _text(self.small, caption), fill="#333333", font=self.small, anchor="ls")
        width = self.layout.size[0]
        draw.text((width - 10, HEADER_HEIGHT / 2), f"{time:6.2f} s", fill="#222222", font=self.clock_font, anchor="rm")
        if self.strip is not None:
            self.strip.paint(frame, self.layout.strip_box[1], time)
        return frame

    def _playing(self, draw: ImageDraw.ImageDraw, box: tuple[int, int, int, int], time: float) -> None:
        """What plays now: one line per active occurrence, with its envelope as a bar
        (markers: the lexemes the face does not draw)."""
        left, top, right, bottom = box
        draw.text((left + 8, top + 14), "playing", fill="#555555", font=self.small, anchor="ls")
        rows: list[tuple[str, str, float | None]] = []
        for key in self.track.keys:
            if key.start <= time < key.stop:
                level = float(abs(key_weight(key, np.array([time]))[0]))
                rows.append((key.modality, f"{key.signal}  {key.lexeme}", level))
        for marker in self.track.active_markers(time):
            rows.append((marker.modality, f"{marker.signal}  {marker.lexeme}  (not drawn)", None))
        for body in self.track.bodies:
            if body.start <= time < body.stop:
                rows.append((body.modality, f"{body.signal}  {body.lexeme}  (body)", None))
        y = top + 24
        for modality, label, weight in rows:
            if y + 18 > bottom:
                break
            colour = LANE_COLOURS.get(modality, OTHER_COLOUR)
            draw.rectangle((left + 8, y + 3, left + 18, y + 13), fill=colour, outline="#333333")
            draw.text((left + 24, y + 8), _text(self.small, label), fill="#222222", font=self.small, anchor="lm")
            if weight is not None:
                bar = (right - left - 40) * min(weight, 1.0)
                draw.rectangle((left + 24, y + 15, left + 24 + bar, y + 17), fill=colour)
            y += 22

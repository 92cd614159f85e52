"""SVG timelines like the paper's figures: one lane per modality, one bar per occurrence.

Pure string building (no plotting library).  Bars are labelled with the author's signal
ids (the lexeme is in the tooltip), never truncated: the drawing widens with the duration
until labels fit, and a bar still too short gets its label beside it.  Overlapping
occurrences of one modality, and bars whose labels would touch, are stacked in sub-rows.
The HTML viewer embeds the same drawing with ``interactive=True`` (data attributes for the
script and a playhead; the page shows the title).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

from mse.export.bml import Behaviour, plan_behaviours, provenance
from mse.export.lexemes import format_seconds
from mse.export.options import ExportOptions
from mse.export.xmltext import Element, element, render
from mse.timeline import Timeline

SVG_NAMESPACE = "http://www.w3.org/2000/svg"
LANE_ORDER: tuple[str, ...] = ("face", "gaze", "head", "gesture", "torso", "posture", "speech")
LANE_COLOURS: Mapping[str, str] = {
    "face": "#e07a5f",
    "gaze": "#3d85c6",
    "head": "#81b29a",
    "gesture": "#f2cc8f",
    "torso": "#9c89b8",
    "posture": "#9c89b8",
    "speech": "#6d6875",
}
OTHER_COLOUR = "#b0b0b0"

WIDTH = 960  # the narrowest drawing; longer timelines get wider (see layout)
LABEL_WIDTH = 88
RIGHT_PAD = 24
TITLE_HEIGHT = 34
RULER_HEIGHT = 26
BAR_HEIGHT = 22
ROW_GAP = 4
LANE_PAD = 7
CHAR_WIDTH = 6.6  # a generous average width of an 11 px sans-serif glyph
LABEL_PAD = 8  # room round a label inside its bar
LABEL_GAP = 6  # room between a bar (or its outside label) and the next bar of the row
MAX_SCALE = 90.0  # pixels per second that the labels may ask for
MAX_DRAWING_WIDTH = 16000
MIN_TICK_SPACING = 64.0  # pixels between ruler ticks
_TICK_STEPS = (0.1, 0.2, 0.25, 0.5, 1.0, 2.0, 5.0, 10.0, 15.0, 30.0, 60.0, 120.0, 300.0, 600.0)


@dataclass(frozen=True, slots=True)
class Bar:
    behaviour: Behaviour
    x: float
    y: float
    width: float
    label: str = ""
    label_inside: bool = True


@dataclass(frozen=True, slots=True)
class Lane:
    modality: str
    y: float
    height: float


@dataclass(frozen=True)
class Layout:
    """Where everything goes; ``x(t) = x0 + t * scale``."""

    width: int
    height: int
    x0: float
    scale: float
    lanes: tuple[Lane, ...]
    bars: tuple[Bar, ...]
    tick_step: float
    top: float = TITLE_HEIGHT + RULER_HEIGHT


def lane_order(modalities: Sequence[str]) -> list[str]:
    present = set(modalities)
    known = [m for m in LANE_ORDER if m in present]
    return known + sorted(m for m in present if m not in LANE_ORDER)


def label_width(text: str) -> float:
    return len(text) * CHAR_WIDTH


def _rows(extents: Sequence[tuple[float, float]]) -> list[int]:
    """Greedy interval colouring in pixels: the first sub-row whose last extent has ended."""
    row_ends: list[float] = []
    rows: list[int] = []
    for start, end in extents:
        for index, row_end in enumerate(row_ends):
            if row_end <= start + 1e-6:
                row_ends[index] = end
                rows.append(index)
                break
        else:
            row_ends.append(end)
            rows.append(len(row_ends) - 1)
    return rows


def tick_step(duration: float, scale: float | None = None) -> float:
    """Ruler step: at most 12 ticks, or (given pixels per second) ticks far enough apart."""
    for step in _TICK_STEPS:
        if scale is not None and step * scale >= MIN_TICK_SPACING:
            return step
        if scale is None and duration / step <= 12:
            return step
    return 60.0 * math.ceil(duration / 720.0) if scale is None else 60.0 * math.ceil(MIN_TICK_SPACING / scale / 60.0)


def time_scale(behaviours: Sequence[Behaviour], duration: float) -> float:
    """Pixels per second: the narrowest drawing, widened (up to :data:`MAX_SCALE`) until
    every occurrence's label fits in its bar."""
    span = max(duration, 1e-3)
    fit = (WIDTH - LABEL_WIDTH - RIGHT_PAD) / span
    needed = max(
        ((label_width(b.signal.id) + LABEL_PAD) / max(b.signal.stop - b.signal.start, 1e-3) for b in behaviours),
        default=0.0,
    )
    widest = (MAX_DRAWING_WIDTH - LABEL_WIDTH - RIGHT_PAD) / span
    return max(fit, min(needed, MAX_SCALE, widest))


def layout(timeline: Timeline, *, title: bool = True) -> Layout:
    """Lanes, bars and labels; labels are the author's signal ids, never cut: a bar too
    short for its label gets the label beside it, and the next bar of that row moves down."""
    behaviours = [replace(b, modality=b.modality or "other") for b in plan_behaviours(timeline)]
    x0 = float(LABEL_WIDTH)
    scale = time_scale(behaviours, timeline.duration)
    top = float((TITLE_HEIGHT if title else 8) + RULER_HEIGHT)
    y = top
    lanes: list[Lane] = []
    bars: list[Bar] = []
    right = x0 + timeline.duration * scale
    for modality in lane_order([b.modality for b in behaviours]) or ["face"]:
        members = [b for b in behaviours if b.modality == modality]
        placed = []
        for b in members:
            x = x0 + b.signal.start * scale
            width = max((b.signal.stop - b.signal.start) * scale, 1.5)
            text = b.signal.id
            inside = label_width(text) + LABEL_PAD <= width
            end = x + width if inside else x + width + 3 + label_width(text)
            placed.append((b, x, width, text, inside, end))
            right = max(right, end)
        # An outside label needs room before the next bar; touching bars may share a row.
        rows = _rows([(x, end if inside else end + LABEL_GAP) for _, x, _, _, inside, end in placed])
        row_count = max(rows, default=0) + 1
        height = 2 * LANE_PAD + row_count * BAR_HEIGHT + (row_count - 1) * ROW_GAP
        for (b, x, width, text, inside, _), row in zip(placed, rows, strict=True):
            bar_y = y + LANE_PAD + row * (BAR_HEIGHT + ROW_GAP)
            bars.append(Bar(b, x, bar_y, width, text, inside))
        lanes.append(Lane(modality, y, height))
        y += height
    width = max(WIDTH, math.ceil(right + RIGHT_PAD))
    step = tick_step(timeline.duration, scale)
    return Layout(width, math.ceil(y + 8), x0, scale, tuple(lanes), tuple(bars), step, top)


def _ruler(geometry: Layout, duration: float) -> list[Element]:
    top = geometry.top
    bottom = geometry.height - 8
    items: list[Element] = []
    count = math.floor(duration / geometry.tick_step + 1e-9)
    for index in range(count + 1):
        t = index * geometry.tick_step
        x = round(geometry.x0 + t * geometry.scale, 2)
        items.append(element("line", {"x1": x, "x2": x, "y1": top - 6, "y2": bottom, "class": "tick"}))
        items.append(element("text", {"x": x, "y": top - 10, "class": "tick-label"}, f"{format_seconds(t)} s"))
    end_x = round(geometry.x0 + duration * geometry.scale, 2)
    items.append(element("line", {"x1": end_x, "x2": end_x, "y1": top - 6, "y2": bottom, "class": "end"}))
    return items


def _bar(bar: Bar, interactive: bool) -> Element:
    b = bar.behaviour
    colour = LANE_COLOURS.get(b.modality, OTHER_COLOUR)
    tooltip = f"{b.signal.id}: {b.signal.lexeme}  {b.start}–{b.end} s"
    x, y, w = round(bar.x, 2), round(bar.y, 2), round(bar.width, 2)
    group_attrs: dict[str, str | float | int | None] = {"class": "bar"}
    if interactive:
        group_attrs.update(
            {
                "data-id": b.signal.id,
                "data-lexeme": b.signal.lexeme,
                "data-modality": b.modality,
                "data-start": b.start,
                "data-stop": b.end,
            }
        )
    rect = element("rect", {"x": x, "y": y, "width": w, "height": BAR_HEIGHT, "rx": 4, "fill": colour})
    children: list[Element] = [element("title", {}, tooltip), rect]
    if bar.label:
        label_x = round(x + 4, 2) if bar.label_inside else round(x + w + 3, 2)
        label_class = "label" if bar.label_inside else "label outside"
        children.append(element("text", {"x": label_x, "y": round(y + 15, 2), "class": label_class}, bar.label))
    return element("g", group_attrs, *children)


_STYLE = (
    "text{font-family:DejaVu Sans,Helvetica,Arial,sans-serif;fill:#222}"
    ".title{font-size:15px;font-weight:bold}.lane-label{font-size:12px;font-weight:bold}"
    ".tick{stroke:#ddd;stroke-width:1}.end{stroke:#888;stroke-width:1;stroke-dasharray:4 3}"
    ".tick-label{font-size:10px;text-anchor:middle;fill:#555}.label{font-size:11px;fill:#111}"
    ".label.outside{fill:#333}"
    ".lane{fill:#f7f7f7}.lane.odd{fill:#eeeeee}.bar rect{stroke:#333;stroke-width:.6}"
)


def svg_element(timeline: Timeline, options: ExportOptions, *, interactive: bool = False) -> Element:
    """The drawing; the viewer (``interactive``) shows the title in the page, not here."""
    geometry = layout(timeline, title=not interactive)
    title = options.title or provenance(timeline)
    children: list[Element] = [
        element("title", {}, title),
        element("style", {}, _STYLE),
        element(
            "rect",
            {"x": 0, "y": 0, "width": geometry.width, "height": geometry.height, "fill": "#fff"},
        ),
    ]
    if not interactive:
        children.append(element("text", {"x": 12, "y": 22, "class": "title"}, title))
    for index, lane in enumerate(geometry.lanes):
        lane_class = "lane odd" if index % 2 else "lane"
        children.append(
            element(
                "rect",
                {
                    "x": 0,
                    "y": round(lane.y, 2),
                    "width": geometry.width,
                    "height": lane.height,
                    "class": lane_class,
                },
            )
        )
    children.extend(_ruler(geometry, timeline.duration))
    children.extend(_bar(bar, interactive) for bar in geometry.bars)
    # Lane names last, on their lane's colour: the viewer keeps this group in view when a long
    # timeline scrolls sideways (bars pass under it).
    names: list[Element] = []
    for index, lane in enumerate(geometry.lanes):
        lane_class = "lane odd" if index % 2 else "lane"
        box: dict[str, str | float | int | None] = {"x": 0, "y": round(lane.y, 2), "width": LABEL_WIDTH - 4}
        box.update({"height": lane.height, "class": lane_class})
        names.append(element("rect", box))
        label_y = round(lane.y + lane.height / 2 + 4, 2)
        names.append(element("text", {"x": 10, "y": label_y, "class": "lane-label"}, lane.modality))
    children.append(element("g", {"id": "lane-names"} if interactive else {}, *names))
    attrs: dict[str, str | float | int | None] = {
        "xmlns": SVG_NAMESPACE,
        "width": geometry.width,
        "height": geometry.height,
        "viewBox": f"0 0 {geometry.width} {geometry.height}",
        "role": "img",
    }
    if interactive:
        top = geometry.top - 6
        children.append(
            element(
                "line",
                {
                    "id": "playhead",
                    "x1": geometry.x0,
                    "x2": geometry.x0,
                    "y1": top,
                    "y2": geometry.height - 8,
                },
            )
        )
        attrs.update(
            {
                "id": "timeline",
                "data-x0": round(geometry.x0, 3),
                "data-scale": round(geometry.scale, 6),
                "data-duration": format_seconds(timeline.duration),
            }
        )
    return element("svg", attrs, *children)


def render_svg(timeline: Timeline, options: ExportOptions) -> str:
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + render(svg_element(timeline, options)) + "\n"

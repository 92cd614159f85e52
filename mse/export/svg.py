"""SVG timelines like the paper's figures: one lane per modality, one bar per occurrence.

Pure string building (no plotting library).  Overlapping occurrences of one modality are
stacked in sub-rows so that no bar hides another.  The HTML viewer embeds the same
drawing with ``interactive=True`` (data attributes for the script and a playhead).
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

WIDTH = 960
LABEL_WIDTH = 88
RIGHT_PAD = 24
TITLE_HEIGHT = 34
RULER_HEIGHT = 26
BAR_HEIGHT = 22
ROW_GAP = 4
LANE_PAD = 7
CHAR_WIDTH = 6.4  # average width of an 11 px sans-serif glyph, for truncating labels
_TICK_STEPS = (0.1, 0.2, 0.25, 0.5, 1.0, 2.0, 5.0, 10.0, 15.0, 30.0, 60.0, 120.0, 300.0, 600.0)


@dataclass(frozen=True, slots=True)
class Bar:
    behaviour: Behaviour
    x: float
    y: float
    width: float


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


def lane_order(modalities: Sequence[str]) -> list[str]:
    present = set(modalities)
    known = [m for m in LANE_ORDER if m in present]
    return known + sorted(m for m in present if m not in LANE_ORDER)


def _rows(behaviours: Sequence[Behaviour]) -> list[int]:
    """Greedy interval colouring: the first sub-row whose last bar has ended."""
    row_ends: list[float] = []
    rows: list[int] = []
    for b in behaviours:
        for index, end in enumerate(row_ends):
            if end <= b.signal.start + 1e-9:
                row_ends[index] = b.signal.stop
                rows.append(index)
                break
        else:
            row_ends.append(b.signal.stop)
            rows.append(len(row_ends) - 1)
    return rows


def tick_step(duration: float) -> float:
    for step in _TICK_STEPS:
        if duration / step <= 12:
            return step
    return 60.0 * math.ceil(duration / 720.0)


def layout(timeline: Timeline) -> Layout:
    behaviours = [replace(b, modality=b.modality or "other") for b in plan_behaviours(timeline)]
    x0 = float(LABEL_WIDTH)
    scale = (WIDTH - LABEL_WIDTH - RIGHT_PAD) / max(timeline.duration, 1e-3)
    y = float(TITLE_HEIGHT + RULER_HEIGHT)
    lanes: list[Lane] = []
    bars: list[Bar] = []
    for modality in lane_order([b.modality for b in behaviours]) or ["face"]:
        members = [b for b in behaviours if b.modality == modality]
        rows = _rows(members)
        row_count = max(rows, default=0) + 1
        height = 2 * LANE_PAD + row_count * BAR_HEIGHT + (row_count - 1) * ROW_GAP
        for b, row in zip(members, rows, strict=True):
            bar_y = y + LANE_PAD + row * (BAR_HEIGHT + ROW_GAP)
            width = max((b.signal.stop - b.signal.start) * scale, 1.5)
            bars.append(Bar(b, x0 + b.signal.start * scale, bar_y, width))
        lanes.append(Lane(modality, y, height))
        y += height
    return Layout(WIDTH, math.ceil(y + 8), x0, scale, tuple(lanes), tuple(bars), tick_step(timeline.duration))


def _label(text: str, width: float) -> str:
    room = int((width - 8) / CHAR_WIDTH)
    if room < 3:
        return ""
    return text if len(text) <= room else text[: room - 1] + "…"


def _ruler(geometry: Layout, duration: float) -> list[Element]:
    top = TITLE_HEIGHT + RULER_HEIGHT
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
    text = _label(b.lexeme.name or b.signal.id, bar.width)
    if text:
        children.append(element("text", {"x": round(x + 4, 2), "y": round(y + 15, 2), "class": "label"}, text))
    return element("g", group_attrs, *children)


_STYLE = (
    "text{font-family:DejaVu Sans,Helvetica,Arial,sans-serif;fill:#222}"
    ".title{font-size:15px;font-weight:bold}.lane-label{font-size:12px;font-weight:bold}"
    ".tick{stroke:#ddd;stroke-width:1}.end{stroke:#888;stroke-width:1;stroke-dasharray:4 3}"
    ".tick-label{font-size:10px;text-anchor:middle;fill:#555}.label{font-size:11px;fill:#111}"
    ".lane{fill:#f7f7f7}.lane.odd{fill:#eeeeee}.bar rect{stroke:#333;stroke-width:.6}"
)


def svg_element(timeline: Timeline, options: ExportOptions, *, interactive: bool = False) -> Element:
    geometry = layout(timeline)
    title = options.title or provenance(timeline)
    children: list[Element] = [
        element("title", {}, title),
        element("style", {}, _STYLE),
        element(
            "rect",
            {"x": 0, "y": 0, "width": geometry.width, "height": geometry.height, "fill": "#fff"},
        ),
        element("text", {"x": 12, "y": 22, "class": "title"}, title),
    ]
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
        label_y = round(lane.y + lane.height / 2 + 4, 2)
        children.append(element("text", {"x": 10, "y": label_y, "class": "lane-label"}, lane.modality))
    children.extend(_ruler(geometry, timeline.duration))
    children.extend(_bar(bar, interactive) for bar in geometry.bars)
    attrs: dict[str, str | float | int | None] = {
        "xmlns": SVG_NAMESPACE,
        "width": geometry.width,
        "height": geometry.height,
        "viewBox": f"0 0 {geometry.width} {geometry.height}",
        "role": "img",
    }
    if interactive:
        top = TITLE_HEIGHT + RULER_HEIGHT - 6
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

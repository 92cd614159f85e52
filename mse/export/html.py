"""A single self-contained HTML page: the face player, the SVG timeline with a playhead,
and a stick-figure player.

Everything is inline (CSS, script, data); a Content-Security-Policy forbids any network
access, so the page works offline and from ``file://``.  The face (:mod:`mse.export.face`)
plays every timeline; the stick-figure player appears when the timeline's signals carry
generated motion (``signal.motion["file"]``, a BVH).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from importlib import resources
from typing import TYPE_CHECKING, Any
from xml.sax.saxutils import escape

from mse.export.bml import provenance
from mse.export.options import ExportOptions
from mse.export.svg import svg_element
from mse.export.xmltext import render
from mse.timeline import Timeline

if TYPE_CHECKING:
    from mse.export.figures import FigureClip

_CSP = "default-src 'none'; style-src 'unsafe-inline'; script-src 'unsafe-inline'; img-src data:"
FIGURE_SIZE = (280, 320)


def _asset(name: str) -> str:
    return resources.files("mse.export").joinpath(name).read_text(encoding="utf-8")


def script_json(value: Any) -> str:
    """JSON that is safe inside ``<script>``: no ``</``, no ``<!--``, no U+2028/9 surprises."""
    text = json.dumps(value, ensure_ascii=True, separators=(",", ":"))
    return text.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")


def _player(clips_json: str) -> str:
    width, height = FIGURE_SIZE
    return (
        '<section id="player" aria-label="stick-figure player">\n'
        f'<canvas id="figure" width="{width}" height="{height}" data-clip="-1" data-frame="-1">'
        "</canvas>\n"
        '<p id="figure-caption"></p>\n'
        "</section>\n"
        f'<script type="application/json" id="mse-motion">{clips_json}</script>\n'
    )


def render_html(
    timeline: Timeline,
    options: ExportOptions,
    figure_clips: Sequence[FigureClip] | None = None,
) -> str:
    """The page; ``figure_clips`` overrides reading motion files named by the timeline."""
    from mse.export import figures
    from mse.export.face.page import face_page

    face = face_page(timeline, options)
    if figure_clips is None:
        figure_clips = figures.clips_from_timeline(timeline, options.motion_base_dir)
    title = options.title or provenance(timeline)
    drawing = render(svg_element(timeline, options, interactive=True))
    player = ""
    if figure_clips:
        player = _player(script_json(figures.payload(figure_clips, options.figure_fps)))
    duration = f"{timeline.duration:.3f}"
    return f"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta http-equiv="Content-Security-Policy" content="{_CSP}">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{escape(title)}</title>
<style>
{_asset("viewer.css")}</style>
</head>
<body>
<h1>{escape(title)}</h1>
<div id="controls">
<button id="play" type="button">Play</button>
<input id="scrub" type="range" min="0" max="{duration}" step="0.01" value="0" aria-label="time">
<span id="clock" data-time="0">0.00 s</span>
</div>
<div id="layout">
<div id="players">
{face.markup}{player}</div>
<div id="stage">
{drawing}
</div>
</div>
<div id="tooltip" role="tooltip" hidden></div>
<footer>{len(timeline.signals)} occurrence(s). Hover a bar for its lexeme and times; space or the
button plays; click the timeline to move the playhead. Made by mse.</footer>
<script type="application/json" id="mse-face">{script_json(face.data)}</script>
<script>
{_asset("viewer.js")}</script>
<script>
{face.script}</script>
</body>
</html>
"""

"""The face in the HTML viewer: an SVG of the rig's shapes, its data and ``face.js``.

The SVG is written for time 0 (so the page shows a face before any script runs); the
script then redraws the same paths for the playhead's time from the embedded compiled rig
and keys.
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib import resources

import numpy as np

from mse.export.face import sources_of
from mse.export.face.lexicon import Resolver
from mse.export.face.rig import Rig, default_rig, pose_points, shape_paths
from mse.export.face.track import Track, build_track, face_view_track
from mse.export.options import ExportOptions
from mse.export.xmltext import Element, element, render
from mse.timeline import Timeline


@dataclass(frozen=True)
class FacePage:
    """The pieces the viewer page embeds."""

    markup: str  # <section id="face-player"> … </section>
    data: dict[str, object]  # JSON for <script id="mse-face">
    script: str  # face.js
    notes: tuple[str, ...]


def face_track(timeline: Timeline, options: ExportOptions, rig: Rig | None = None) -> Track:
    return build_track(timeline, rig or default_rig(), Resolver(sources_of(options)))


def face_svg(rig: Rig, track: Track, time: float = 0.0) -> Element:
    values = track.values(np.array([time]))[0]
    children: list[Element] = [
        element("rect", {"width": rig.view_box[0], "height": rig.view_box[1], "fill": rig.background})
    ]
    for shape, (path, alpha) in zip(rig.shapes, shape_paths(rig, pose_points(rig, values), values), strict=True):
        attrs: dict[str, str | float | int | None] = {
            "class": "face-shape",
            "data-shape": shape.id,
            "d": path or "M 0 0",
            "fill": shape.fill or "none",
            "stroke": shape.stroke if shape.stroke and shape.width > 0 else None,
            "stroke-width": shape.width if shape.stroke and shape.width > 0 else None,
            "opacity": f"{alpha:.3f}",
            "visibility": "visible" if path else "hidden",
        }
        children.append(element("path", attrs))
    width, height = rig.view_box
    return element(
        "svg",
        {
            "xmlns": "http://www.w3.org/2000/svg",
            "id": "face",
            "viewBox": f"0 0 {width:g} {height:g}",
            "width": f"{width:g}",
            "height": f"{height:g}",
            "role": "img",
            "aria-label": "the agent's face, head, gaze and torso at the playhead",
            "data-time": "0.000",
        },
        *children,
    )


def face_page(timeline: Timeline, options: ExportOptions) -> FacePage:
    rig = default_rig()
    # The page shows the face view: gestures (the half-body view's arms) are markers.
    track = face_view_track(face_track(timeline, options, rig), rig)
    notes = ""
    if track.notes:
        items = "".join(f"<li>{_escape(note)}</li>" for note in track.notes)
        notes = f'<details id="face-notes"><summary>{len(track.notes)} note(s)</summary><ul>{items}</ul></details>\n'
    markup = (
        '<section id="face-player" aria-label="face player">\n'
        f"{render(face_svg(rig, track))}\n"
        '<div id="face-markers" aria-live="polite"></div>\n'
        f"{notes}"
        "</section>\n"
    )
    script = resources.files("mse.export.face").joinpath("face.js").read_text(encoding="utf-8")
    return FacePage(markup, {"rig": rig.to_json(), "track": track.to_json()}, script, track.notes)


def _escape(text: str) -> str:
    from xml.sax.saxutils import escape

    return escape(text)

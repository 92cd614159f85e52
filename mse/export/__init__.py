"""Timelines out to realizers and people: BML 1.0, Greta BML, SVG, HTML, ELAN (EAF 3.0), and
tracks (OpenFace 2.0 CSV, ARKit blendshapes: docs/tracks.md).

``render(timeline, "bml")`` returns the text of one format.  Exporter modules are imported
on first use, so ``import mse.export`` stays cheap for the command line.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import cast

from mse.diagnostics import Diagnostic, MseError, Span, argument_error
from mse.export.options import ExportOptions
from mse.timeline import Timeline

__all__ = ["BINARY_FORMATS", "FORMAT_NAMES", "VIDEO_FORMATS", "ExportOptions", "export_notes", "render", "render_bytes"]

Renderer = Callable[[Timeline, ExportOptions], str]

#: format name -> (module, function); the module is imported when the format is used.
_REGISTRY: dict[str, tuple[str, str]] = {
    "bml": ("mse.export.bml", "render_bml"),
    "greta-bml": ("mse.export.greta_bml", "render_greta_bml"),
    "svg": ("mse.export.svg", "render_svg"),
    "html": ("mse.export.html", "render_html"),
    "eaf": ("mse.export.eaf", "render_eaf"),
    "openface": ("mse.export.tracks.openface", "render_openface"),
    "arkit": ("mse.export.tracks.arkit", "render_arkit"),
    "arkit-json": ("mse.export.tracks.arkit", "render_arkit_json"),
}

FORMAT_NAMES: tuple[str, ...] = tuple(_REGISTRY)
DEFAULT_OPTIONS = ExportOptions()

#: File suffix of each format (the CLI names files written into a folder with it).
SUFFIXES: dict[str, str] = {"bml": ".bml", "greta-bml": ".xml", "svg": ".svg", "html": ".html", "eaf": ".eaf"}
SUFFIXES.update({"openface": ".openface.csv", "arkit": ".arkit.csv", "arkit-json": ".arkit.json"})

#: Binary formats written by :func:`render_bytes` (format name -> (module, function)).
_BINARY_REGISTRY: dict[str, tuple[str, str]] = {"vrma": ("mse.export.tracks.vrma", "render_vrma")}
BINARY_FORMATS: tuple[str, ...] = tuple(_BINARY_REGISTRY)
SUFFIXES["vrma"] = ".vrma"

#: Binary formats written to a file by ``mse.export.video.write_video`` (not ``render``).
VIDEO_FORMATS: tuple[str, ...] = ("mp4", "webm", "gif")
SUFFIXES.update({"mp4": ".mp4", "webm": ".webm", "gif": ".gif"})


def renderer(fmt: str) -> Renderer:
    """The function that writes ``fmt``; unknown names raise MseError (E130)."""
    entry = _REGISTRY.get(fmt)
    if entry is None:
        known = ", ".join(FORMAT_NAMES)
        raise argument_error(f"unknown export format {fmt!r} (known: {known})")
    module = importlib.import_module(entry[0])
    return cast(Renderer, getattr(module, entry[1]))


def render(timeline: Timeline, fmt: str, options: ExportOptions = DEFAULT_OPTIONS) -> str:
    """The text of ``timeline`` in format ``fmt`` (one of :data:`FORMAT_NAMES`)."""
    if not isinstance(timeline, Timeline):
        raise MseError([Diagnostic("E212", "export needs a Timeline", Span("<export>"))])
    return renderer(fmt)(timeline, options)


def render_bytes(timeline: Timeline, fmt: str, options: ExportOptions = DEFAULT_OPTIONS) -> bytes:
    """The bytes of ``timeline`` in binary format ``fmt`` (one of :data:`BINARY_FORMATS`)."""
    if not isinstance(timeline, Timeline):
        raise MseError([Diagnostic("E212", "export needs a Timeline", Span("<export>"))])
    entry = _BINARY_REGISTRY.get(fmt)
    if entry is None:
        raise argument_error(f"unknown binary export format {fmt!r} (known: {', '.join(BINARY_FORMATS)})")
    function = getattr(importlib.import_module(entry[0]), entry[1])
    return cast(bytes, function(timeline, options))


def export_notes(
    timeline: Timeline, fmt: str, options: ExportOptions = DEFAULT_OPTIONS, where: str = "<export>"
) -> list[Diagnostic]:
    """Warnings about what ``render(timeline, fmt, options)`` leaves out (W601: a torso the
    Greta profile cannot play; W602: a lexeme the face player cannot show, in the viewer and
    videos); empty for formats and profiles that write every occurrence."""
    if fmt == "html" or fmt in VIDEO_FORMATS:
        from mse.export.face.page import face_track

        return [Diagnostic("W602", note, Span(where)) for note in face_track(timeline, options).notes]
    if fmt not in ("bml", "greta-bml"):
        return []
    from mse.export.realizers import realizer_for

    if realizer_for(fmt, options.realizer) != "greta":
        from mse.export.bml import core_lexeme_notes

        return core_lexeme_notes(timeline, options, where)
    from mse.export.greta_bml import greta_notes

    return greta_notes(timeline, options, where)

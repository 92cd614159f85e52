"""SVG and HTML exporters, checked as text and XML (the browser tests drive the page)."""

from __future__ import annotations

import itertools
import json
import re
from pathlib import Path

import numpy as np
import pytest
from lxml import etree

from mse.diagnostics import MseError
from mse.export import ExportOptions, render
from mse.export.figures import FigureClip, motion_file, payload, resample
from mse.export.html import render_html, script_json
from mse.export.svg import layout, tick_step
from mse.timeline import Timeline, TimelineSignal, loads_many

FIXTURE = Path(__file__).resolve().parent / "fixtures" / "export" / "embarrassment_timeline.json"
SVG = "{http://www.w3.org/2000/svg}"


@pytest.fixture(scope="module")
def embarrassment() -> Timeline:
    return loads_many(FIXTURE.read_text(encoding="utf-8"), path=str(FIXTURE))[0]


def test_svg_has_one_bar_per_occurrence_and_lanes(embarrassment: Timeline) -> None:
    root = etree.fromstring(render(embarrassment, "svg").encode("utf-8"))
    bars = root.findall(f"{SVG}g[@class='bar']")
    assert len(bars) == len(embarrassment.signals)
    lane_labels = [t.text for t in root.iter(f"{SVG}text") if t.get("class") == "lane-label"]
    assert lane_labels == ["face", "gaze", "head", "gesture", "torso"]
    titles = [t.text or "" for t in root.iter(f"{SVG}text") if t.get("class") == "title"]
    assert titles == ["embarrassment — 10 s — solver hand-made — seed none"]
    ticks = [t.text for t in root.iter(f"{SVG}text") if t.get("class") == "tick-label"]
    assert ticks[0] == "0 s" and ticks[-1] == "10 s"
    labels = [t.text or "" for t in root.iter(f"{SVG}text") if (t.get("class") or "").startswith("label")]
    assert sorted(labels) == sorted(s.id for s in embarrassment.signals)  # the author's ids
    tooltips = [t.text or "" for t in root.iter(f"{SVG}title")]
    assert any("embarrassment_signal_6" in t for t in tooltips)  # the lexeme on hover


def test_overlapping_occurrences_stack_in_sub_rows() -> None:
    signals = (
        TimelineSignal("a", "face", "faceexp=smile", 0.0, 2.0),
        TimelineSignal("b", "face", "faceexp=frown", 1.0, 3.0),
        TimelineSignal("c", "face", "faceexp=smile", 2.0, 3.0),
    )
    geometry = layout(Timeline("x", 3.0, signals))
    rows = {bar.behaviour.signal.id: bar.y for bar in geometry.bars}
    assert rows["a"] == rows["c"] != rows["b"]
    assert len(geometry.lanes) == 1


def test_tick_step_keeps_the_ruler_readable() -> None:
    assert tick_step(10.0) == 1.0
    assert tick_step(3.0) == 0.25
    assert 600 / tick_step(600.0) <= 12
    assert 10_000 / tick_step(10_000.0) <= 12


def test_html_is_self_contained(embarrassment: Timeline) -> None:
    page = render(embarrassment, "html")
    assert page.startswith("<!DOCTYPE html>")
    assert not re.search(r"(src|href)\s*=\s*[\"']?(https?:)?//", page)
    assert "<link" not in page and "@import" not in page
    assert "Content-Security-Policy" in page and "default-src 'none'" in page
    assert page.count('class="bar"') == len(embarrassment.signals)
    assert 'id="figure"' not in page  # no motion in this timeline: no player


def test_html_embeds_figure_clips_safely(embarrassment: Timeline) -> None:
    positions = np.zeros((60, 2, 3))
    positions[:, 1, 1] = np.linspace(10.0, 20.0, 60)
    clip = FigureClip("10", "</script><b>", 2.5, 5.0, 60.0, ("root", "head"), (-1, 0), positions)
    page = render_html(embarrassment, ExportOptions(), [clip])
    assert 'id="figure"' in page and "</script><b>" not in page
    data = re.search(r'<script type="application/json" id="mse-motion">(.*?)</script>', page)
    assert data is not None
    decoded = json.loads(data.group(1))
    assert decoded["clips"][0]["lexeme"] == "</script><b>"
    assert len(decoded["clips"][0]["frames"]) == 30  # 60 frames at 60 fps -> 30 fps
    assert decoded["bounds"][:3] == [0.0, 0.0, 0.0] and 19.5 < decoded["bounds"][3] <= 20.0


def test_resample_and_payload_shapes() -> None:
    positions = np.arange(120 * 3 * 3, dtype=np.float64).reshape(120, 3, 3)
    assert resample(positions, 120.0, 30.0).shape == (30, 3, 3)
    assert resample(positions, 30.0, 30.0) is positions
    assert payload([], 30)["clips"] == []
    assert script_json({"a": "<!--"}) == '{"a":"\\u003c!--"}'


def test_motion_file_resolution(tmp_path: Path) -> None:
    signal = TimelineSignal("g", "gesture", "x", 0.0, 1.0, motion={"file": "clips/g.bvh"})
    assert motion_file(signal, tmp_path) == tmp_path / "clips" / "g.bvh"
    assert motion_file(TimelineSignal("g", "gesture", "x", 0.0, 1.0), tmp_path) is None


def test_missing_motion_file_is_a_diagnostic(tmp_path: Path, embarrassment: Timeline) -> None:
    first = embarrassment.signals[0]
    moving = TimelineSignal(first.id, first.modality, first.lexeme, first.start, first.stop, {"file": "x.bvh"})
    timeline = embarrassment.with_signals([moving, *embarrassment.signals[1:]])
    with pytest.raises(MseError) as error:
        render(timeline, "html", ExportOptions(motion_base_dir=tmp_path))
    assert error.value.diagnostics[0].code == "E100"


def test_real_bvh_clip_in_the_viewer(bandai_dir: Path) -> None:
    clip_path = min(bandai_dir.rglob("*.bvh"))
    signal = TimelineSignal("bow", "torso", "torso=bow", 0.5, 2.5, {"file": clip_path.name})
    timeline = Timeline("bow", 3.0, (signal,))
    page = render(timeline, "html", ExportOptions(motion_base_dir=clip_path.parent))
    data = re.search(r'<script type="application/json" id="mse-motion">(.*?)</script>', page)
    assert data is not None
    clip = json.loads(data.group(1))["clips"][0]
    assert len(clip["joints"]) == len(clip["parents"]) == 22
    assert len(clip["frames"]) == 61  # 2 s at 30 fps, plus the last frame
    assert len(clip["frames"][0]) == 2 * 22


def _sampled(duration: float, seed: int) -> Timeline:
    from mse.api import load
    from mse.sampling import sample

    result = sample(load("embarrassment"), duration, seed=seed)
    assert isinstance(result, Timeline)
    return result


@pytest.mark.parametrize("duration", [10.0, 30.0, 60.0])
def test_long_timelines_keep_every_label_whole_and_apart(duration: float) -> None:
    """At 30 s and 60 s every bar has its whole id, and no label touches another one."""
    from mse.export.svg import LABEL_PAD, label_width

    for seed in (1, 2, 3):
        timeline = _sampled(duration, seed)
        geometry = layout(timeline)
        assert {bar.label for bar in geometry.bars} == {s.id for s in timeline.signals}
        rows: dict[float, list[tuple[float, float]]] = {}
        for bar in geometry.bars:
            assert "…" not in bar.label
            left = bar.x if bar.label_inside else bar.x + bar.width + 3
            right = left + label_width(bar.label)
            if bar.label_inside:
                assert right + LABEL_PAD / 2 <= bar.x + bar.width + 1e-6
            rows.setdefault(bar.y, []).append((bar.x, max(right, bar.x + bar.width)))
        for row in rows.values():
            row.sort()
            for (_, end), (next_start, _) in itertools.pairwise(row):
                assert end <= next_start + 1e-6  # a bar or its label never runs into the next bar
        assert geometry.width >= 960
        root = etree.fromstring(render(timeline, "svg").encode("utf-8"))
        assert int(root.get("width") or 0) == geometry.width


def test_drawing_widens_with_duration_and_ticks_stay_apart() -> None:
    from mse.export.svg import MIN_TICK_SPACING

    short, long = layout(_sampled(10.0, 1)), layout(_sampled(60.0, 1))
    assert long.width > short.width
    assert long.tick_step * long.scale >= MIN_TICK_SPACING
    assert short.tick_step == 1.0


def test_html_shows_the_title_once(embarrassment: Timeline) -> None:
    page = render(embarrassment, "html")
    title = "embarrassment — 10 s — solver hand-made — seed none"
    visible = re.sub(r"<title>.*?</title>", "", page, flags=re.S)
    assert visible.count(title) == 1  # the <h1>; the drawing inside the page has none
    assert 'id="face"' in page and 'id="mse-face"' in page


def test_text_table_labels_never_run_together() -> None:
    from mse.cli.table import render_table

    for seed in range(1, 6):
        timeline = _sampled(30.0, seed)
        table = render_table(timeline)
        lane_lines = table.split("\n\n")[0].splitlines()[3:]
        ids = {s.id for s in timeline.signals}
        for line in lane_lines:
            for token in line[10:].split():
                assert token.rstrip("=") in ids, (token, line)

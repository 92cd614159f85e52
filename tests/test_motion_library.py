"""Motion libraries: the plain index, the Bandai reader, the emotion -> style table."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from mse.diagnostics import MseError
from mse.motion.base.bvh import write_bvh
from mse.motion.base.library import load_library, style_for_emotion
from mse.motion.base.starter import generate_clip


def test_emotion_table_and_overrides() -> None:
    assert style_for_emotion("anger") == "angry"
    assert style_for_emotion("cheerfulness") == "happy"
    assert style_for_emotion("pride") == "proud"
    assert style_for_emotion("embarrassment") == "not-confident"
    assert style_for_emotion("emotion-sadness") == "sad"
    assert style_for_emotion("something-new") == "normal"
    assert style_for_emotion("anger", {"anger": "furious"}) == "furious"


def test_bandai_reader(bandai_dir: Path) -> None:
    library = load_library(bandai_dir)
    assert len(library.clips) >= 170
    assert {"bow", "walk", "guide"} <= set(library.actions())
    assert {"normal", "happy", "sad", "angry", "proud", "not-confident", "tired", "active"} <= set(library.styles())
    (bow_sad,) = library.select("bow", "sad")
    assert bow_sad.id == "dataset-1_bow_sad_001"
    assert library.motion(bow_sad).frame_count > 100
    assert library.style_for("embarrassment") == "not-confident"
    assert library.content_hash == load_library(bandai_dir).content_hash
    # behaviour sets name actions with identifiers: walk_back is Bandai's walk-back
    assert library.action_named("walk_back") == "walk-back"
    assert library.action_named("walk") == "walk"
    assert library.action_named("no_such_action") == "no_such_action"


def _write_clips(folder: Path) -> None:
    write_bvh(folder / "a.bvh", generate_clip("bow", "sad", 0))
    write_bvh(folder / "b.bvh", generate_clip("bow", "angry", 1))


def test_json_index(tmp_path: Path) -> None:
    _write_clips(tmp_path)
    index = {
        "format": "mse-motion-library/1",
        "emotion_styles": {"anger": "rage"},
        "clips": [
            {"file": "a.bvh", "action": "bow", "style": "sad", "performer": "p1"},
            {"file": "b.bvh", "action": "bow", "style": "rage", "id": "bow-rage"},
        ],
    }
    (tmp_path / "library.json").write_text(json.dumps(index))
    library = load_library(tmp_path)
    assert [c.id for c in library.clips] == ["a", "bow-rage"]
    assert library.style_for("anger") == "rage"
    assert library.motion(library.clips[0]).frame_count > 10


def test_csv_index(tmp_path: Path) -> None:
    _write_clips(tmp_path)
    (tmp_path / "library.csv").write_text("file,action,style,performer\na.bvh,bow,sad,p1\nb.bvh,bow,angry,p2\n")
    library = load_library(tmp_path)
    assert library.select("bow", "angry")[0].performer == "p2"


def test_index_errors_point_at_the_line(tmp_path: Path) -> None:
    _write_clips(tmp_path)
    (tmp_path / "library.csv").write_text("file,action,style,performer\na.bvh,bow,sad,p1\nzz.bvh,bow,sad,p\n")
    with pytest.raises(MseError) as caught:
        load_library(tmp_path)
    assert caught.value.diagnostics[0].span.line == 3
    with pytest.raises(MseError):
        load_library(tmp_path / "missing")
    (tmp_path / "library.csv").unlink()
    with pytest.raises(MseError):
        load_library(tmp_path)

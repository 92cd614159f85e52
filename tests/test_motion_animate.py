"""``animate``: files, durations, annotations, fallbacks."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from mse.diagnostics import MseError
from mse.ir.model import Model, MotionLeaf, Signal
from mse.motion.animate import MotionWarning, animate
from mse.motion.base.bvh import read_bvh
from mse.motion.base.library import load_library
from mse.timeline import Timeline, TimelineSignal

REPO = Path(__file__).resolve().parent.parent


def _model(action: str = "head_down") -> Model:
    return Model(
        "embarrassment",
        (
            Signal("look_down", "head", "head=down", motion=MotionLeaf(action)),
            Signal("bow", "torso", "torso=bow", motion=MotionLeaf("bow")),
            Signal("smile", "face", "face=smile"),
        ),
    )


def _timeline() -> Timeline:
    return Timeline(
        "embarrassment",
        6.0,
        (
            TimelineSignal("look_down", "head", "head=down", 0.5, 1.75, {"action": "head_down"}),
            TimelineSignal("smile", "face", "face=smile", 1.0, 2.0),
            TimelineSignal("bow", "torso", "torso=bow", 2.0, 4.321),
            TimelineSignal("look_down", "head", "head=down", 4.5, 5.5),
        ),
    )


def test_annotations_before_animation() -> None:
    assert _model().motion_annotations == {
        "look_down": {"action": "head_down"},
        "bow": {"action": "bow"},
    }


@pytest.mark.slow
def test_animate_with_the_starter_library(tmp_path: Path) -> None:
    result = animate(_timeline(), _model(), tmp_path)
    motions = [s for s in result.signals if s.motion is not None]
    assert len(motions) == 3
    for signal in motions:
        assert signal.motion is not None
        assert signal.motion["emotion"] == "embarrassment"
        assert signal.motion["style"] == "not-confident"
        clip = read_bvh(tmp_path / signal.motion["file"])
        assert clip.duration == pytest.approx(signal.stop - signal.start, abs=1e-9)
    whole = read_bvh(tmp_path / "timeline.bvh")
    assert whole.duration == pytest.approx(6.0)
    features = json.loads((tmp_path / "lma.json").read_text())
    assert set(features) == {s.motion["file"] for s in motions if s.motion}
    assert "whole_body" in next(iter(features.values()))
    smile = next(s for s in result.signals if s.id == "smile")
    assert smile.motion is None
    assert result.to_json()["animation"]["library"] == "starter"


def test_unknown_action_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(MseError) as caught:
        animate(_timeline(), _model("moonwalk"), tmp_path)
    assert "moonwalk" in caught.value.diagnostics[0].message


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore:.*another skeleton")
def test_fallback_warns_with_the_action(bandai_dir: Path, tmp_path: Path) -> None:
    data = bandai_dir / "data"
    entries = [
        {"file": str(data / f"dataset-1_bow_{style}_001.bvh"), "action": "bow", "style": style}
        for style in ("normal", "not-confident", "sad")
    ]
    (tmp_path / "library.json").write_text(json.dumps({"clips": entries}))
    library = load_library(tmp_path)
    with pytest.warns(MotionWarning, match="head_down"):
        result = animate(_timeline(), _model(), tmp_path / "out", library)
    bow = next(s for s in result.signals if s.id == "bow")
    assert bow.motion is not None
    assert read_bvh(tmp_path / "out" / bow.motion["file"]).skeleton.joint_count == 22


def test_motion_modules_import_no_heavy_packages() -> None:
    code = (
        "import sys, mse.motion.animate, mse.motion.lma_hmm.generate, mse.motion.base.lma, mse.motion.lma_hmm.search, "
        "mse.motion.lma_hmm.hmm, mse.motion.base.library, mse.motion.base.starter, mse.motion.base.compose, "
        "mse.motion.base.filters, mse.cli.cmd_lma, mse.cli.cmd_animate; "
        "print([m for m in ('scipy', 'sklearn', 'hmmlearn') if m in sys.modules])"
    )
    found = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO, check=True)
    assert found.stdout.strip() == "[]"

"""The issue's cases on Bandai data: generated clips perform their action (shared data)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bench.evaluation.fidelity import check, measure, reference, repeated
from mse.motion.base.bvh import read_bvh
from mse.motion.base.library import load_library
from mse.motion.generator import GenerationRequest, generator_for

pytestmark = pytest.mark.slow


def _library(bandai_dir: Path, tmp_path: Path, action: str, styles: tuple[str, ...], takes: int = 1) -> Path:
    data = bandai_dir / "data"
    entries = [
        {"file": str(data / f"dataset-1_{action}_{style}_{take:03d}.bvh"), "action": action, "style": style}
        for style in styles
        for take in range(1, takes + 1)
    ]
    (tmp_path / "library.json").write_text(json.dumps({"clips": entries}))
    return tmp_path


@pytest.mark.parametrize("method", ["lma-hmm", "hsmm"])
def test_angry_bow_bows(bandai_dir: Path, tmp_path: Path, method: str) -> None:
    # the issue: lma-hmm's angry bow moved the head by 0.5 cm, HSMM bows jittered
    library = load_library(_library(bandai_dir, tmp_path, "bow", ("normal", "angry", "sad")))
    motion = generator_for(method, tmp_path / "cache").generate(library, GenerationRequest("bow", "angry", 3.0))
    # checked against the real bows of all fifteen styles, as bench/evaluation/motion_fidelity.py does
    real = [read_bvh(path) for path in sorted((bandai_dir / "data").glob("dataset-1_bow_*.bvh"))]
    angry = [read_bvh(bandai_dir / "data" / "dataset-1_bow_angry_001.bvh")]
    values = measure(motion)
    checks = {c.name: c for c in check(values, reference("bow", real), reference("bow", angry))}
    dip = checks["head_dip"]
    assert dip.passed, f"head dip {dip.value:.1f} cm, real bows {dip.low:.1f}-{dip.high:.1f}"
    assert values["reversals"] < 0.05  # HSMM hands reversed on 95 % of frames
    assert values["jerk"] < 3 * checks["jerk"].high  # 70,000 cm/s^3 before; the bench has the 2x table


@pytest.mark.parametrize("method", ["lma-hmm", "hsmm"])
def test_walks_travel_without_skating(bandai_dir: Path, tmp_path: Path, method: str) -> None:
    # the issue: lma-hmm walks slid their lowest foot at a median 124 cm/s
    library = load_library(_library(bandai_dir, tmp_path, "walk", ("normal", "sad"), takes=2))
    motion = generator_for(method, tmp_path / "cache").generate(library, GenerationRequest("walk", "sad", 4.0))
    values = measure(motion)
    assert values["foot_slip"] < 2.0  # cm/s; real walks 0.5-9
    assert values["forward_speed"] > 20.0


@pytest.mark.parametrize(
    ("action", "style"),
    [("walk-left", "sad"), ("walk-back", "musical"), ("dash", "not-confident"), ("run", "childish")],
)
def test_lma_hmm_travels_at_the_real_pace_at_every_length(
    bandai_dir: Path, tmp_path: Path, action: str, style: str
) -> None:
    # issue 35: at 1x the root moved back by 3.7 cm in a frame (sad sidesteps: a foot put
    # down still swinging), at 2x the dash stopped and stood in its last state (0 steps/s)
    data = bandai_dir / "data"
    files = sorted(data.glob(f"dataset-1_{action}_*.bvh"))
    entries = [{"file": str(f), "action": action, "style": f.stem.split("_")[2]} for f in files]
    (tmp_path / "library.json").write_text(json.dumps({"clips": entries}))
    library = load_library(tmp_path)
    real = [library.motion(c) for c in library.clips]
    own = [library.motion(c) for c in library.clips if c.style == style]
    action_reference, style_reference = reference(action, real), reference(action, own)
    generator = generator_for("lma-hmm", tmp_path / "cache")
    for factor in (1, 2, 3):
        motion = generator.generate(library, GenerationRequest(action, style, factor * own[0].duration))
        failed = [c for c in check(measure(motion), action_reference, style_reference) if not c.passed]
        assert not failed, f"x{factor}: " + ", ".join(
            f"{c.name} {c.value:.2f} [{c.low:.2f}, {c.high:.2f}]" for c in failed
        )


def test_a_one_shot_held_at_rest_keeps_its_hand_range(bandai_dir: Path, tmp_path: Path) -> None:
    # issue 35: the musical bye at 2x failed hand_range (72.2 against 67.5), measured from the
    # wrist's mean position: its wave follows the normal take's timing (hand up 2.9 s, real
    # 4.8 s) and the rest pose held after it moved the mean. The wrist's widest reach is
    # measured now: the real take's at every length, the generated clip's within 1 cm of it
    data = bandai_dir / "data"
    files = sorted(data.glob("dataset-1_bye_*.bvh"))
    entries = [{"file": str(f), "action": "bye", "style": f.stem.split("_")[2]} for f in files]
    (tmp_path / "library.json").write_text(json.dumps({"clips": entries}))
    library = load_library(tmp_path)
    real = [library.motion(c) for c in library.clips]
    own = [library.motion(c) for c in library.clips if c.style == "musical"]
    action_reference, style_reference = reference("bye", real), reference("bye", own)
    generator = generator_for("lma-hmm", tmp_path / "cache")
    for factor in (1, 2, 3):
        checked = repeated(action_reference, real, factor)
        assert checked.values["hand_range"] == pytest.approx(action_reference.values["hand_range"])
        values = measure(generator.generate(library, GenerationRequest("bye", "musical", factor * own[0].duration)))
        assert values["hand_range"] == pytest.approx(style_reference.values["hand_range"][0], abs=1.0)
        failed = [c for c in check(values, checked, style_reference) if not c.passed]
        assert not failed, f"x{factor}: " + ", ".join(
            f"{c.name} {c.value:.2f} [{c.low:.2f}, {c.high:.2f}]" for c in failed
        )

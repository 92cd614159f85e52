"""``<motion method="hsmm">`` leaves through ``mse.motion.animate``: the HSMM method serves
them (no lma-hmm fallback) with clips of exactly the scheduled duration."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from mse.ir.model import Model, MotionLeaf, Signal
from mse.motion.animate import MotionWarning, animate
from mse.motion.base.bvh import Motion, read_bvh
from mse.motion.base.library import MotionLibrary, load_library
from mse.motion.hsmm import leaf
from mse.timeline import Timeline, TimelineSignal


def _spy(monkeypatch: pytest.MonkeyPatch) -> list[tuple[str, str, float]]:
    """Record the calls ``animate`` makes to the HSMM leaf entry point."""
    calls: list[tuple[str, str, float]] = []
    real = leaf.synthesize_leaf

    def spy(source: MotionLibrary, action: str, style: str, duration_s: float, **kw: object) -> Motion:
        calls.append((action, style, duration_s))
        return real(source, action, style, duration_s, **kw)  # type: ignore[arg-type]

    monkeypatch.setattr(leaf, "synthesize_leaf", spy)
    return calls


def _animate(
    tmp_path: Path, action: str, library: MotionLibrary | None, spans: list[tuple[float, float]]
) -> Timeline:
    model = Model("sadness", (Signal("move", "torso", "torso=move", motion=MotionLeaf(action, method="hsmm")),))
    timeline = Timeline(
        "sadness", 6.0, tuple(TimelineSignal("move", "torso", "torso=move", a, b) for a, b in spans)
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error", MotionWarning)  # a fallback to lma-hmm would warn
        return animate(timeline, model, tmp_path / "out", library)


@pytest.mark.slow
def test_hsmm_bow_leaf_on_the_starter_library(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MSE_CACHE_DIR", str(tmp_path / "cache"))
    calls = _spy(monkeypatch)
    result = _animate(tmp_path, "bow", None, [(0.5, 2.5), (3.0, 4.25)])
    assert [c[0] for c in calls] == ["bow", "bow"]
    for signal in result.signals:
        assert signal.motion is not None
        clip = read_bvh(tmp_path / "out" / signal.motion["file"])
        assert clip.duration == pytest.approx(signal.stop - signal.start, abs=1e-9)
        assert np.all(np.isfinite(clip.values))
    assert read_bvh(tmp_path / "out" / "timeline.bvh").duration == pytest.approx(6.0)


@pytest.mark.slow
def test_hsmm_walk_leaf_on_bandai(bandai_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MSE_CACHE_DIR", str(tmp_path / "cache"))
    library = load_library(bandai_dir)
    walks = tuple(
        c for c in library.select(action="walk") if c.id.endswith("_001") and c.style in ("normal", "sad")
    )
    small = MotionLibrary("bandai-walks", walks)
    calls = _spy(monkeypatch)
    result = _animate(tmp_path, "walk", small, [(1.0, 3.5)])
    (signal,) = result.signals
    assert calls == [("walk", "sad", pytest.approx(2.5))]
    assert signal.motion is not None and signal.motion["style"] == "sad"
    clip = read_bvh(tmp_path / "out" / signal.motion["file"])
    assert clip.duration == pytest.approx(2.5, abs=1e-9)
    assert clip.skeleton.same_layout(small.motion(walks[0]).skeleton)
    assert list((tmp_path / "cache" / "hsmm").glob("*.npz"))  # average and adapted models cached

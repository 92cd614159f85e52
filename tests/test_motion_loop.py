"""Longer requests repeat an action's cycles at their tempo (issue 35, mse/motion/base/loop.py)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from bench.evaluation.fidelity import measure
from mse.motion.base.library import load_library
from mse.motion.base.loop import loop_span, looped
from mse.motion.generator import METHODS, GenerationRequest, generator_for


def _cycle(frames: int, period: float) -> np.ndarray:
    t = np.arange(frames)
    rise = np.clip(t / 10.0, 0.0, 1.0) * np.clip((frames - t) / 10.0, 0.0, 1.0)
    return np.column_stack([rise * np.sin(2 * np.pi * t / period), rise * np.cos(2 * np.pi * t / period), rise])


def _rate(signal: np.ndarray) -> float:
    crossings = np.count_nonzero(np.diff(np.sign(signal)) != 0)
    return crossings / (2.0 * len(signal))


def test_a_loop_keeps_the_tempo_and_the_amplitude() -> None:
    values = _cycle(120, 20.0)
    longer = looped(values, 360, 1.0 / 30.0)
    assert longer.shape == (360, 3)
    middle = slice(60, 300)
    assert abs(_rate(longer[middle, 0]) - 1.0 / 20.0) < 0.005  # cycles per frame, as the clip's
    assert np.ptp(longer[middle, 0]) > 1.9  # full swings, not the rise stretched


def test_a_loop_spans_whole_periods_and_leaves_the_rise_and_fall_once() -> None:
    values = _cycle(120, 20.0)
    start, end = loop_span(values, period=20.0)
    assert start >= 12 and end <= 119
    assert abs((end - start) / 20.0 - round((end - start) / 20.0)) <= 0.15


def test_a_request_not_longer_than_the_clip_is_left_alone() -> None:
    values = _cycle(120, 20.0)
    assert looped(values, 120, 1.0 / 30.0) is values


def test_a_run_twice_its_length_keeps_its_pace(bandai_dir: Path, tmp_path: Path) -> None:
    # one take per style (Bandai dataset 1): the LMA + HMM method plays it as itself; stretched
    # to twice its length it ran 1.25 steps/s at 121 cm/s (the take: 2.73, 261)
    data = bandai_dir / "data"
    entries = [
        {"file": str(data / f"dataset-1_run_{style}_001.bvh"), "action": "run", "style": style}
        for style in ("normal", "tired")
    ]
    (tmp_path / "library.json").write_text(json.dumps({"clips": entries}))
    library = load_library(tmp_path)
    take = library.motion(library.clips[0])
    real = measure(take)
    for method in METHODS:
        motion = generator_for(method, None).generate(library, GenerationRequest("run", "normal", 2 * take.duration))
        generated = measure(motion)
        assert generated["step_rate"] > 0.8 * real["step_rate"], method
        assert generated["forward_speed"] > 0.75 * real["forward_speed"], method
        assert generated["backward"] < 0.5, method

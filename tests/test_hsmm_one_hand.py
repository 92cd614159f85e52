"""A wave longer than its clips keeps swinging (issue 35 item 3): HSMM repeats the swings of a
hand cycle (from the end of the rise to the start of the fall), not the stretch whose ends
join best, which for a wave of swings and holds was a hold (a feminine one-hand wave made
from Bandai dataset 2 takes held still for 13 s at twice its length).

../shared holds no one-hand wave; ``bench.evaluation.one_hand`` makes them from the two-hand
takes (the left arm at rest)."""

from __future__ import annotations

import numpy as np
import pytest

from bench.evaluation.one_hand import ONE_HAND_ACTION, one_hand_library, wave_measures
from mse.motion.base.cycles import action_shape
from mse.motion.base.library import MotionLibrary
from mse.motion.generator import GenerationRequest, generator_for

STYLES = ("active", "normal", "youthful", "feminine")


@pytest.fixture(scope="module")
def waves(bandai_ds2: MotionLibrary) -> MotionLibrary:
    source = bandai_ds2
    keep = []
    for style in STYLES:
        keep.extend(sorted(source.select("wave-both-hands", style), key=lambda c: c.id)[:3])
    return one_hand_library(MotionLibrary("waves", tuple(keep)), "wave-both-hands")


@pytest.mark.slow
def test_a_one_hand_wave_keeps_swinging_at_three_times_its_length(waves: MotionLibrary) -> None:
    assert action_shape([waves.motion(c) for c in waves.clips]).cycle == "hands"
    generator = generator_for("hsmm", None)
    for style in ("feminine", "normal"):
        own = [waves.motion(c) for c in waves.select(ONE_HAND_ACTION, style)]
        real = [wave_measures(m) for m in own]
        length = float(np.median([m.duration for m in own]))
        motion = generator.generate(waves, GenerationRequest(ONE_HAND_ACTION, style, 3 * length))
        generated = wave_measures(motion)
        assert generated["longest_hold_s"] <= 1.15 * max(r["longest_hold_s"] for r in real), style
        assert generated["frequency"] >= 0.85 * min(r["frequency"] for r in real), style

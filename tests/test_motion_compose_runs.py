"""A composed run keeps the flight its generator gave it (mse animate, timeline.bvh)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from bench.evaluation.fidelity import check, measure, reference
from mse.motion.base.compose import Track, compose
from mse.motion.base.library import load_library


@pytest.mark.slow
def test_a_composed_run_keeps_its_speed_and_its_feet(bandai_dir: Path) -> None:
    """Bandai dataset 1, LMA + HMM: the musical run alone on the timeline. Re-grounded from
    the feet alone, the composite lost its flight phases: 243 -> 167 cm/s, its stance foot
    sliding at 124 cm/s (limit 26)."""
    from mse.motion.lma_hmm.generate import generate_motion

    library = load_library(bandai_dir)
    clips = library.select("run")
    own = [library.motion(c) for c in clips if c.style == "musical"]
    duration = float(np.median([m.duration for m in own]))
    motion = generate_motion(library, "run", "musical", duration=duration).motion
    composed = compose(motion.slice(0, 1), [Track(0.0, motion)], motion.duration, motion.frame_time)
    alone, together = measure(motion), measure(composed)
    assert together["forward_speed"] == pytest.approx(alone["forward_speed"], rel=0.02)
    checks = check(together, reference("run", [library.motion(c) for c in clips]), reference("run", own))
    assert all(c.passed for c in checks), [c for c in checks if not c.passed]

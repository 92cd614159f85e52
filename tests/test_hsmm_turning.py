"""Turning locomotion (issue 35 item 3): locomotion whose heading changes, measured from the
clips (never from the action's name), is segmented into steps as straight walks are, and
turns at the rate of its clips at every length; the fidelity measures follow the path.

../shared holds no turning walk, so the tests bend real Bandai dataset 2 walks along a curve
(``bench.evaluation.turning.curved``)."""

from __future__ import annotations

import numpy as np
import pytest

from bench.evaluation.fidelity import measure
from bench.evaluation.turning import TURN_ACTION, curved, turning_library, turning_measures, walk_takes
from mse.motion.base.heading import TURN_DEG_PER_S, smoothed_yaws, turn_rate, turning_rate
from mse.motion.base.library import MotionLibrary

RATE = np.radians(20.0)


@pytest.fixture(scope="module")
def walks(bandai_ds2: MotionLibrary) -> MotionLibrary:
    # four takes of three styles: enough for an average model and an adaptation
    return walk_takes(bandai_ds2, ("normal", "feminine", "active"))


def test_smoothed_yaws_keep_a_steady_turn_to_the_ends() -> None:
    ramp = np.linspace(0.0, 2.0, 90)
    assert np.allclose(smoothed_yaws(ramp, 1.0 / 30.0), ramp)


def test_the_turn_rate_is_measured_from_the_clips(walks: MotionLibrary) -> None:
    straight = [walks.motion(c) for c in walks.clips]
    bent = [curved(m, RATE) for m in straight]
    assert turning_rate(straight) == 0.0  # Bandai's straight walks turn under TURN_DEG_PER_S
    assert all(abs(np.degrees(turn_rate(m))) < TURN_DEG_PER_S for m in straight)
    assert turning_rate(bent) == pytest.approx(RATE, rel=0.15)
    assert turning_rate([curved(m, -RATE) for m in straight]) == pytest.approx(-RATE, rel=0.15)


def test_measures_follow_a_turning_path(walks: MotionLibrary) -> None:
    """A bent walk has the steps, speed and forward progress of its straight take: measured
    along a straight line, its hips went backwards on the far side of the turn."""
    take = walks.motion(walks.clips[0])
    straight, bent = measure(take), measure(curved(take, RATE))
    assert bent["turn_rate"] == pytest.approx(20.0, rel=0.15)
    assert bent["step_rate"] == pytest.approx(straight["step_rate"], rel=0.1)
    assert bent["forward_speed"] == pytest.approx(straight["forward_speed"], rel=0.1)
    assert bent["backward"] <= straight["backward"] + 1e-6
    assert turning_measures(curved(take, RATE))["backward_max"] == 0.0


@pytest.mark.slow
def test_hsmm_segments_a_turning_walk_into_steps_and_turns_at_its_rate(walks: MotionLibrary) -> None:
    from mse.motion.hsmm.leaf import train_from_library
    from mse.motion.hsmm.synth import synthesize

    library = turning_library(walks, "walk", RATE)
    average = train_from_library(library, TURN_ACTION)
    assert average.template.turning and average.cycle == "steps"
    assert {u.split("-")[0] for u in average.units} == {"first", "inner", "last"}  # steps, not one block
    assert float(average.info["turn_rate"]) == pytest.approx(RATE, rel=0.15)  # type: ignore[arg-type]
    real = [turning_measures(library.motion(c)) for c in library.clips]
    length = float(np.median([library.motion(c).duration for c in library.clips]))
    for factor in (1.0, 2.0, 3.0):
        generated = turning_measures(synthesize(average, duration_s=factor * length, seed=0))
        assert generated["turn_deg_per_s"] == pytest.approx(20.0, rel=0.15), factor
        assert min(r["steps_per_s"] for r in real) * 0.9 <= generated["steps_per_s"], factor
        assert generated["steps_per_s"] <= max(r["steps_per_s"] for r in real) * 1.1, factor
        assert generated["speed"] >= 0.8 * min(r["speed"] for r in real), factor
        assert generated["backward_max"] <= 0.2, factor  # cm; the real takes: 0


def test_straight_locomotion_is_not_turning(walks: MotionLibrary) -> None:
    from mse.motion.hsmm.api import train_average

    model = train_average([(walks.motion(c), c.style) for c in walks.clips[:4]], "walk")
    assert not model.template.turning and "turn_rate" not in model.info

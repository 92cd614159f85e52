"""LMA + HMM turning locomotion (issue 35 item 3): locomotion whose heading changes, measured
from the clips (never from the action's name), is generated straight from its clips
straightened to their paths' heading, and turns at the clips' rate at every length, its hips
never going back along the path.

../shared holds no turning walk, so the tests bend real Bandai dataset 2 walks along a curve
(``bench.evaluation.turning.curved``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from bench.evaluation.turning import TURN_ACTION, turning_library, turning_measures, walk_takes
from mse.motion.base.heading import heading_track, straightened, turn_rate
from mse.motion.base.library import MotionLibrary
from mse.motion.lma_hmm.generate import action_turn_of, generate_motion

RATE = np.radians(20.0)


@pytest.fixture(scope="module")
def walks(bandai_ds2: MotionLibrary) -> MotionLibrary:
    # four takes of three styles: enough for an average model and an adaptation
    return walk_takes(bandai_ds2, ("normal", "elderly", "active"))


def test_a_straightened_turning_walk_goes_straight(walks: MotionLibrary) -> None:
    library = turning_library(walks, "walk", RATE)
    bent = library.motion(library.clips[0])
    straight = straightened(bent)
    assert np.degrees(turn_rate(bent)) == pytest.approx(20.0, rel=0.15)
    assert abs(np.degrees(turn_rate(straight))) < 1.0
    assert np.ptp(heading_track(straight)) < np.radians(5.0)  # the smoothing of a smoothed track
    # the steps are the same steps: speed along the path unchanged
    assert turning_measures(straight)["speed"] == pytest.approx(turning_measures(bent)["speed"], rel=0.02)


def test_only_turning_locomotion_turns(walks: MotionLibrary) -> None:
    assert action_turn_of(walks, "walk") == 0.0
    assert action_turn_of(turning_library(walks, "walk", RATE), TURN_ACTION) == pytest.approx(RATE, rel=0.15)
    assert action_turn_of(turning_library(walks, "walk", -RATE), TURN_ACTION) == pytest.approx(-RATE, rel=0.15)


@pytest.mark.slow
@pytest.mark.parametrize("style", ["elderly", "normal"])
def test_lma_hmm_turns_a_turning_walk_at_its_rate_and_pace(walks: MotionLibrary, style: str) -> None:
    """Elderly: converted from the normal take (before: 14 cm/s against 64-91, the hips back on
    40 % of frames); normal: its own take, looped at 2x and 3x (before: 9 deg/s, 67 cm/s)."""
    library = turning_library(walks, "walk", RATE)
    own = [library.motion(c) for c in library.select(TURN_ACTION, style)]
    real = [turning_measures(m) for m in own]
    length = float(np.median([m.duration for m in own]))
    low = {k: min(r[k] for r in real) for k in ("steps_per_s", "speed", "turn_deg_per_s")}
    high = {k: max(r[k] for r in real) for k in ("steps_per_s", "speed", "turn_deg_per_s")}
    for factor in (1.0, 2.0, 3.0):
        motion = generate_motion(library, TURN_ACTION, style, duration=factor * length).motion
        generated = turning_measures(motion)
        assert 0.9 * low["turn_deg_per_s"] <= generated["turn_deg_per_s"] <= 1.1 * high["turn_deg_per_s"], factor
        assert 0.9 * low["steps_per_s"] <= generated["steps_per_s"] <= 1.1 * high["steps_per_s"], factor
        assert 0.9 * low["speed"] <= generated["speed"] <= 1.1 * high["speed"], factor
        assert generated["backward_max"] <= max(r["backward_max"] for r in real) + 0.01, factor  # cm


def test_a_turning_path_keeps_its_turn_on_disk(walks: MotionLibrary, tmp_path: Path) -> None:
    from mse.motion.base import cache

    library = turning_library(walks, "walk", RATE)
    cache.forget("modulated")
    first = generate_motion(library, TURN_ACTION, "normal", duration=4.0, cache_dir=tmp_path)
    cache.forget("modulated")
    again = generate_motion(library, TURN_ACTION, "normal", duration=4.0, cache_dir=tmp_path)
    assert again.cached and not first.cached
    np.testing.assert_allclose(again.motion.values, first.motion.values, atol=1e-9)
    assert turning_measures(again.motion)["turn_deg_per_s"] == pytest.approx(20.0, rel=0.15)

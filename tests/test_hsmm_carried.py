"""HSMM flight phases (per-state carried values) and hand cycles (waves cut at the hands'
turns): the estimators on synthetic data, and a run on real Bandai clips (skipped without
the shared data)."""

from __future__ import annotations

import itertools
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from mse.motion.base.library import MotionLibrary, load_library
from mse.motion.hsmm import api
from mse.motion.hsmm.carried import STANCE_SHARE, carried_profiles, carried_track
from mse.motion.hsmm.io import load_model, save_model
from mse.motion.hsmm.model import HsmmModel, Instance, UnitModel
from mse.motion.hsmm.segment import hand_sway, segment_clip


def _unit(states: int, width: int, duration: float) -> UnitModel:
    return UnitModel(
        means=np.zeros((states, width)),
        variances=np.ones((states, width)),
        duration_means=np.full(states, duration),
        duration_variances=np.ones(states),
    )


def test_carried_profiles_average_each_state_and_map_towards_the_prior() -> None:
    unit = _unit(2, 3, 5.0)
    # two states of five frames each, told apart by the observations
    observations = np.vstack([np.full((5, 3), -3.0), np.full((5, 3), 3.0)])
    unit = replace(unit, means=np.array([[-3.0] * 3, [3.0] * 3]))
    carried = np.vstack([np.tile([1.0, 10.0, 0.0, 1.0], (5, 1)), np.tile([0.0, 30.0, 4.0, 0.0], (5, 1))])
    instance = Instance("inner-a", "x", observations, (0, 5, 10), carried)
    profile = carried_profiles({"inner-a": unit}, [instance])["inner-a"]
    assert np.allclose(profile, carried[[0, 5]])
    prior = {"inner-a": np.zeros((2, 4)), "inner-b": np.ones((2, 4))}
    adapted = carried_profiles({"inner-a": unit}, [instance], prior=prior)
    # a prior worth one visit (5 frames) against 5 frames of data: half-way
    assert np.allclose(adapted["inner-a"], carried[[0, 5]] / 2)
    assert np.allclose(adapted["inner-b"], 1.0)  # no data: the prior


def test_carried_track_follows_durations_scales_speed_and_rounds_stance() -> None:
    unit = _unit(2, 3, 4.0)
    profile = np.array([[0.0, 100.0, 0.0, STANCE_SHARE + 0.05], [0.0, 200.0, 3.0, 0.2]])
    track = carried_track([unit], [profile], np.array([8, 8]))
    assert track is not None and track.shape == (16, 4)
    # played at twice its natural length (8 frames a state, not 4): half the speed
    assert np.allclose(track[:8, 1], 50.0) and np.allclose(track[8:, 1], 100.0)
    assert np.all(track[:8, 3] == 1.0) and np.allclose(track[8:, 3], 0.2)
    assert carried_track([unit], [None], np.array([4, 4])) is None


def test_hand_sway_cuts_a_wave_at_its_turns() -> None:
    frame_time = 1.0 / 30.0
    frames = 180
    t = np.arange(frames) * frame_time
    positions = np.zeros((frames, 3, 3))
    positions[:, 0, 0] = 10.0 * np.sin(2 * np.pi * 1.0 * t)  # left hand sways at 1 Hz
    positions[:, 1, 0] = 1.0 * np.sin(2 * np.pi * 1.0 * t)  # right hand barely
    sway = hand_sway(positions, (0, 1), 2, frame_time)
    segments = segment_clip(frames, True, sway)
    inner = [s for s in segments if s.unit.startswith("inner")]
    assert len(inner) >= 8
    assert all(abs(s.length - 15) <= 2 for s in inner)  # half a period
    legs = [s.unit[-1] for s in segments]
    assert all(a != b for a, b in itertools.pairwise(legs))  # sides alternate


@pytest.fixture(scope="module")
def run_library(bandai_dir: Path) -> MotionLibrary:
    library = load_library(bandai_dir)
    keep = [c for c in library.clips if c.action == "run" and c.style in ("normal", "sad", "happy")]
    return MotionLibrary("bandai-runs", tuple(keep))


@pytest.mark.slow
def test_generated_runs_fly_and_the_profiles_survive_a_file(run_library: MotionLibrary, tmp_path: Path) -> None:
    clips = [(run_library.motion(c), c.style) for c in run_library.select(action="run")]
    model = api.train_average(clips, "run")
    assert model.carried and set(model.carried) <= set(model.units)
    assert min(float(p[:, 3].min()) for p in model.carried.values()) < 0.5  # flight states

    def speed(m: HsmmModel) -> float:
        motion = api.synthesize(m, duration_s=3.0, seed=1)
        root = motion.positions()[:, model.template.root_joint]
        return float((root[-1, 2] - root[0, 2]) / motion.duration)

    real = []
    for motion, _ in clips:
        root = motion.positions()[:, model.template.root_joint]
        real.append(float(np.linalg.norm(root[-1, [0, 2]] - root[0, [0, 2]]) / motion.duration))
    flying, pinned = speed(model), speed(replace(model, carried={}))
    # flight carries the hips further than stance-pinning alone (1.17x since pinned hips no
    # longer step back at stance changes: base/contacts.root_track forward=True)
    assert flying > 1.1 * pinned
    assert 0.7 * min(real) < flying < 1.3 * max(real)
    path = tmp_path / "run.npz"
    save_model(path, model)
    loaded = load_model(path)
    assert set(loaded.carried) == set(model.carried)
    assert all(np.allclose(loaded.carried[k], model.carried[k]) for k in model.carried)

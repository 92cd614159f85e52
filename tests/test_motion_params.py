"""Every option of ``GenerationParams`` (LMA + HMM) takes effect (issue 35: the options a user
sets, each covered by a test; modes typed). On the embedded starter library."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mse.motion.base.library import MotionLibrary, load_library
from mse.motion.base.starter import starter_library
from mse.motion.lma_hmm.generate import Generated, GenerationParams, generate_motion
from mse.motion.lma_hmm.params import Regenerate, Timing, Velocity


def _generate(action: str = "shrug", **options: object) -> Generated:
    params = GenerationParams(**options)  # type: ignore[arg-type]
    return generate_motion(starter_library(), action, "angry", duration=1.5, params=params)


def test_the_neighbourhood_is_widened_and_cut_to_its_bounds() -> None:
    assert len(_generate(min_neighbours=2, max_neighbours=2).neighbours) == 2
    assert len(_generate(min_neighbours=1, max_neighbours=1).neighbours) == 1


def test_epsilon_fraction_sets_the_neighbourhood_before_its_bounds() -> None:
    narrow = _generate(epsilon_fraction=0.0, min_neighbours=1, max_neighbours=50)
    wide = _generate(epsilon_fraction=10.0, min_neighbours=1, max_neighbours=50)
    assert len(narrow.neighbours) < len(wide.neighbours)


@pytest.mark.parametrize(
    ("options", "other"),
    [
        ({"topology": "full"}, {"topology": "left-to-right"}),
        ({"n_iter": 1}, {}),
    ],
)
def test_each_option_changes_the_clip(options: dict[str, object], other: dict[str, object]) -> None:
    changed, base = _generate(**options), _generate(**other)
    assert changed.motion.frame_count == base.motion.frame_count
    assert not np.allclose(changed.motion.values, base.motion.values)


@pytest.mark.parametrize(
    ("options", "other"),
    [({"velocity": "always"}, {}), ({"velocity": "always", "velocity_weight": 1.0}, {"velocity": "always"})],
)
@pytest.mark.slow
def test_the_velocity_enters_the_phase_space_of_cycles(
    bandai_dir: Path, options: dict[str, object], other: dict[str, object]
) -> None:
    library = load_library(bandai_dir)
    walks = MotionLibrary("walks", tuple(c for c in library.select("walk") if c.style in ("normal", "sad", "happy")))
    clips = [
        generate_motion(walks, "walk", "sad", duration=3.0, params=GenerationParams(**o))  # type: ignore[arg-type]
        for o in (options, other)
    ]
    assert clips[0].cyclic
    assert not np.allclose(clips[0].motion.values, clips[1].motion.values)


def test_modes_are_typed() -> None:
    from typing import get_args

    assert get_args(Regenerate) == ("means", "frames")
    assert get_args(Timing) == ("neighbours", "desired")
    assert get_args(Velocity) == ("standing", "always", "never")

"""Both motion methods decide from the clips, never from the action's name: a library whose
actions are renamed ("walk" -> "a1") generates the same clips (issue 35)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from mse.motion.base.cycles import action_shape
from mse.motion.base.library import MotionLibrary, load_library
from mse.motion.generator import METHODS, GenerationRequest, generator_for

STYLES = ("normal", "sad", "happy")
ACTIONS = ("walk", "byebye", "bow")


@pytest.fixture(scope="module")
def libraries(bandai_dir: Path) -> tuple[MotionLibrary, MotionLibrary, dict[str, str]]:
    library = load_library(bandai_dir)
    keep = tuple(c for c in library.clips if c.style in STYLES and c.action in ACTIONS)
    names = {action: f"a{17 + k}" for k, action in enumerate(ACTIONS)}
    renamed = tuple(replace(c, action=names[c.action]) for c in keep)
    return MotionLibrary("named", keep), MotionLibrary("renamed", renamed), names


@pytest.mark.slow
@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("action", ACTIONS)
def test_renamed_actions_generate_the_same_clips(
    libraries: tuple[MotionLibrary, MotionLibrary, dict[str, str]], method: str, action: str, tmp_path: Path
) -> None:
    named, renamed, names = libraries
    generator = generator_for(method, None)
    for duration in (2.0, 6.0):
        original = generator.generate(named, GenerationRequest(action, "sad", duration))
        other = generator.generate(renamed, GenerationRequest(names[action], "sad", duration))
        assert original.frame_count == other.frame_count
        assert original.frame_time == other.frame_time
        np.testing.assert_array_equal(original.values, other.values)


def test_what_an_action_does_is_measured_from_its_clips(
    libraries: tuple[MotionLibrary, MotionLibrary, dict[str, str]],
) -> None:
    named, _, _ = libraries
    shapes = {a: action_shape([named.motion(c) for c in named.select(a)]) for a in ACTIONS}
    assert shapes["walk"].travels and shapes["walk"].cycle == "steps"
    assert not shapes["bow"].travels and shapes["bow"].cycle == "none"
    assert not shapes["byebye"].travels

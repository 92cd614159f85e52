"""The embedded starter library."""

from __future__ import annotations

import numpy as np
import pytest

from mse.diagnostics import MseError
from mse.motion.base.lma import lma_features
from mse.motion.base.starter import (
    PERFORMERS,
    STYLE_EFFORT,
    _generate,
    generate_clip,
    starter_actions,
    starter_library,
)

REQUIRED = {
    "bow",
    "head_down",
    "hand_on_mouth",
    "arms_raised",
    "hands_on_hips",
    "shrug",
    "arms_crossed",
    "fist_raise",
    "hand_on_face",
    "step_back",
    "lean_forward",
    "lean_back",
    "head_turn",
    # used by the bundled behaviour sets too
    "fist_clench",
    "hands_clasp",
    "hands_outward",
}


def test_every_required_action_in_every_style() -> None:
    assert set(starter_actions()) >= REQUIRED
    library = starter_library()
    for action in REQUIRED:
        for style in STYLE_EFFORT:
            assert len(library.select(action, style)) == PERFORMERS


def test_unknown_action_lists_known_ones() -> None:
    with pytest.raises(MseError) as caught:
        generate_clip("moonwalk", "normal")
    message = caught.value.diagnostics[0].message
    assert "moonwalk" in message and "hands_on_hips" in message


def test_deterministic_and_finite() -> None:
    first = generate_clip("shrug", "happy", 1)
    again = _generate.__wrapped__("shrug", "happy", 1)  # bypass the in-process cache
    assert np.array_equal(first.values, again.values)
    assert np.all(np.isfinite(first.values))
    assert not np.array_equal(first.values, generate_clip("shrug", "happy", 2).values)


def test_effort_drives_the_styles() -> None:
    weight = {
        style: np.mean([lma_features(generate_clip("arms_raised", style, p)).whole_body["weight"] for p in range(2)])
        for style in ("angry", "active", "sad", "tired")
    }
    assert min(weight["angry"], weight["active"]) > max(weight["sad"], weight["tired"])


def test_bone_lengths_constant() -> None:
    motion = generate_clip("step_back", "angry", 0)
    positions = motion.positions()
    parents = motion.skeleton.parents
    lengths = np.array(
        [np.linalg.norm(positions[:, j] - positions[:, parents[j]], axis=-1) for j in range(1, len(parents))]
    )
    assert np.allclose(lengths, lengths[:, :1], atol=1e-9)

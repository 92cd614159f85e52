"""HSMM locomotion's hips never move against the direction of travel (issue 35): the real
Bandai takes never do; generated steps did through stance changes and at the clip's ends."""

from __future__ import annotations

import numpy as np

from mse.motion.hsmm.synth import forward_only


def _path(progress: np.ndarray, side: float = 0.0) -> np.ndarray:
    target = np.zeros((len(progress), 3))
    target[:, 2] = progress
    target[:, 0] = side * np.sin(np.arange(len(progress)) / 5.0)  # a sway across the path
    target[:, 1] = 90.0
    return target


def test_a_step_back_is_flattened_and_the_rest_kept() -> None:
    progress = np.cumsum(np.full(60, 2.0))
    progress[20:25] -= np.array([1.0, 3.0, 4.0, 3.0, 1.0])  # the hips go back, then on
    target = _path(progress, side=3.0)
    fixed = forward_only(target, np.zeros_like(target))
    assert np.diff(fixed[:, 2]).min() >= -1e-9
    assert np.allclose(fixed[:, [0, 1]], target[:, [0, 1]])  # sway and height untouched
    assert fixed[-1, 2] == target[-1, 2]  # the same distance in all
    untouched = forward_only(_path(np.cumsum(np.full(60, 2.0))), np.zeros((60, 3)))
    assert np.array_equal(untouched, _path(np.cumsum(np.full(60, 2.0))))


def test_on_a_turning_path_the_direction_of_travel_turns_with_it() -> None:
    frames = 120
    yaws = np.linspace(0.0, np.pi, frames)  # half a circle
    steps = np.stack([np.sin(yaws), np.cos(yaws)], axis=1) * 2.0
    steps[40:44] *= -0.5  # four frames back along the path
    target = np.zeros((frames, 3))
    target[1:, [0, 2]] = np.cumsum(steps[1:], axis=0)
    fixed = forward_only(target, np.zeros_like(target), yaws)
    moves = np.diff(fixed[:, [0, 2]], axis=0)
    heading = np.stack([np.sin(yaws[1:]), np.cos(yaws[1:])], axis=1)
    assert (np.sum(moves * heading, axis=1) >= -1e-6).all()
    # measured on a straight line from start to end, the far side of the arc goes "back"
    chord = target[-1, [0, 2]] - target[0, [0, 2]]
    assert (np.diff(target[:, [0, 2]], axis=0) @ chord).min() < 0

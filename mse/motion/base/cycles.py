"""What an action's clips do, measured from the clips: whether the body travels, and which
limbs carry a cycle (the feet's steps, the hands' swings, or none).

Both methods decide from this, never from the action's name: a user's library holds its own
actions under its own names (a test renames every action of a library and checks that the
generated clips do not change).

* **travels**: the root goes somewhere. Per clip, the mean horizontal distance the root covers
  in :data:`TRAVEL_WINDOW_S` (the body's sway and a dancer's steps back and forth cancel out
  within it; a turning walk's curve mostly does not), in leg lengths per second; the action
  travels when the clips' median is at least :data:`TRAVEL_LEG_LENGTHS_PER_S`. Bandai real
  clips, medians per action: walks, runs and dashes of every direction 0.85-3.5, every other
  action at most 0.16 (the dance; slash 0.10, the rest under 0.05).
* **steps**: a travelling action cycles by its feet (the feet's forward separation alternates
  at each heel strike).
* **hands**: a standing action cycles by its hands when at least :data:`HAND_CYCLE_SHARE` of
  its clips swing a hand side to side regularly (:func:`swings_regularly`). Bandai: dataset 2's
  wave-both-hands in all its clips; dataset 1's bye (5 of 15 clips) and byebye (8 of 15)
  are waves in some styles and a single gesture in others, so they are one-shot; raise, bow,
  guide, punch, kick, slash, dance never (the dance and the kick swing their arms wide but
  irregularly: intervals between turns vary by 75-87 % of their mean).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np

from mse.extras import require
from mse.motion.base.bodyparts import body_map, limb_groups
from mse.motion.base.bvh import Motion, Skeleton
from mse.motion.base.contacts import find_root_joint
from mse.motion.base.heading import heading_track, in_heading_frame
from mse.motion.base.kinematics import FloatArray

__all__ = [
    "ActionShape",
    "CycleKind",
    "action_shape",
    "detrended_sway",
    "leg_length",
    "step_boundaries",
    "swings_regularly",
]

#: which limbs carry an action's cycle
CycleKind = Literal["steps", "hands", "none"]

#: the root travels when it covers at least this many leg lengths per second (see the module)
TRAVEL_LEG_LENGTHS_PER_S = 0.3
#: window over which the root's travel is measured (s): longer than a body's sway
TRAVEL_WINDOW_S = 4.0
#: the hands' side-to-side position is detrended by its moving average over this long (s)
SWAY_DETREND_S = 1.0
#: a clip swings its hand regularly with at least this many turns ...
MIN_SWING_TURNS = 6
#: ... a median swing (turn to turn) of at least this many arm lengths ...
MIN_SWING_ARM_LENGTHS = 0.3
#: ... and intervals between turns varying by at most this share of their mean (Bandai
#: waves 0.04-0.24; dance, kick, punch, guide 0.5-1.2)
MAX_SWING_IRREGULARITY = 0.3
#: an action cycles by its hands when at least this share of its clips swing regularly
HAND_CYCLE_SHARE = 2.0 / 3.0


@dataclass(frozen=True, slots=True)
class ActionShape:
    """What the clips of one action do (:func:`action_shape`)."""

    travels: bool
    cycle: CycleKind
    #: the cycle's period (s; two steps, or a swing there and back), the clips' median; 0: none
    period_s: float = 0.0

    @property
    def cyclic(self) -> bool:
        return self.cycle != "none"


def leg_length(skeleton: Skeleton) -> float:
    """Hip to ankle (down the first child) of the skeleton's legs, file units."""
    legs = set(limb_groups(skeleton)["legs"])
    length = 0.0
    joint = next((j for j in legs if skeleton.parents[j] not in legs), None)
    while joint is not None:  # hip -> knee -> ankle ... down the first child
        children = [c for c in legs if skeleton.parents[c] == joint]
        if not children:
            break
        joint = children[0]
        length += float(np.linalg.norm(skeleton.offsets[joint]))
    return length


def step_boundaries(signal: FloatArray, min_gap: int) -> list[int]:
    """Frames of the alternating extrema of a cycle signal (the feet's forward separation:
    heel strikes; a hand's sway: the turns of a wave)."""
    with require("motion"):
        from scipy.signal import find_peaks

    x = np.asarray(signal, dtype=np.float64)
    if x.size < 3:
        return []
    centred = x - np.median(x)
    amplitude = float(np.percentile(np.abs(centred), 90))
    if amplitude <= 1e-9:
        return []
    prominence = 0.5 * amplitude
    front, _ = find_peaks(centred, distance=min_gap, prominence=prominence)
    back, _ = find_peaks(-centred, distance=min_gap, prominence=prominence)
    events = sorted([(int(i), 1) for i in front] + [(int(i), -1) for i in back])
    strikes: list[tuple[int, int]] = []
    for frame, side in events:
        if centred[frame] * side < 0.3 * amplitude:
            continue  # an extremum on the wrong side of the median is not a strike
        if strikes and strikes[-1][1] == side:
            # Two extrema on the same side in a row: keep the larger one.
            if abs(centred[frame]) > abs(centred[strikes[-1][0]]):
                strikes[-1] = (frame, side)
            continue
        strikes.append((frame, side))
    return [frame for frame, _ in strikes]


def detrended_sway(relative: FloatArray, frame_time: float) -> FloatArray:
    """Of (T, k) side-to-side hand positions against the chest, the one that sways most,
    minus its moving average over :data:`SWAY_DETREND_S` (raising and lowering the arms is
    not a swing): its alternating extrema are the turns of a wave."""
    window = max(3, round(SWAY_DETREND_S / frame_time) | 1)
    kernel = np.ones(window) / window
    detrended = np.empty_like(relative)
    for k in range(relative.shape[1]):
        padded = np.pad(relative[:, k], (window // 2, window // 2), mode="edge")
        detrended[:, k] = relative[:, k] - np.convolve(padded, kernel, mode="valid")
    result: FloatArray = detrended[:, int(np.argmax(detrended.std(axis=0)))]
    return result


def _side_axis(positions: FloatArray, left_hip: int, right_hip: int) -> FloatArray:
    lateral = positions[0, left_hip] - positions[0, right_hip]
    lateral[1] = 0.0
    norm = float(np.linalg.norm(lateral))
    return lateral / norm if norm > 1e-9 else np.array([1.0, 0.0, 0.0])


def step_period(motion: Motion, positions: FloatArray | None = None) -> float:
    """Seconds per cycle of two steps: twice the median interval between the alternating
    extrema of the feet's separation along its main horizontal axis, the separation taken in
    the path's heading frame (:func:`mse.motion.base.heading.heading_track`): on a turning
    path the separation turns with the walker, and along one fixed axis the strikes of the
    steps across it were lost (0: fewer than two)."""
    body = body_map(motion.skeleton)
    positions = motion.positions() if positions is None else positions
    separation = positions[:, body.left_foot][:, [0, 2]] - positions[:, body.right_foot][:, [0, 2]]
    if len(separation) < 4:
        return 0.0
    separation = in_heading_frame(separation, heading_track(motion, positions))
    centred = separation - separation.mean(axis=0)
    _, _, axes = np.linalg.svd(centred, full_matrices=False)
    strikes = step_boundaries(centred @ axes[0], max(2, round(0.15 / motion.frame_time)))
    if len(strikes) < 2:
        return 0.0
    return 2.0 * float(np.median(np.diff(strikes))) * motion.frame_time


@dataclass(frozen=True, slots=True)
class _Sway:
    """The hand that sways most, side to side against the chest, and the frames it turns."""

    arm: float  # arm length (the clip's units)
    sway: FloatArray
    turns: list[int]


def _sway_of(motion: Motion, positions: FloatArray | None) -> _Sway:
    body = body_map(motion.skeleton)
    positions = motion.positions() if positions is None else positions
    side = _side_axis(positions, body.left_hip, body.right_hip)
    hands = positions[:, [body.left_hand, body.right_hand]] - positions[:, [body.torso]]
    sway = detrended_sway(hands @ side, motion.frame_time)
    upper = np.linalg.norm(positions[:, body.right_elbow] - positions[:, body.right_shoulder], axis=-1)
    lower = np.linalg.norm(positions[:, body.right_wrist] - positions[:, body.right_elbow], axis=-1)
    arm = max(float(np.mean(upper + lower)), 1e-9)
    return _Sway(arm, sway, step_boundaries(sway, max(2, round(0.2 / motion.frame_time))))


def swing_period(motion: Motion, positions: FloatArray | None = None) -> float:
    """Seconds per swing there and back of the hand that sways most (0: fewer than two turns)."""
    turns = _sway_of(motion, positions).turns
    if len(turns) < 2:
        return 0.0
    return 2.0 * float(np.median(np.diff(turns))) * motion.frame_time


def swings_regularly(motion: Motion, positions: FloatArray | None = None) -> bool:
    """Whether a hand of ``motion`` swings side to side regularly (see the module)."""
    found = _sway_of(motion, positions)
    turns = found.turns
    if len(turns) < MIN_SWING_TURNS:
        return False
    swings = np.abs(np.diff(found.sway[turns])) / found.arm
    intervals = np.diff(turns).astype(np.float64)
    irregularity = float(np.std(intervals) / max(float(np.mean(intervals)), 1e-9))
    return float(np.median(swings)) >= MIN_SWING_ARM_LENGTHS and irregularity <= MAX_SWING_IRREGULARITY


def travel_rate(motion: Motion, positions: FloatArray | None = None) -> float:
    """Leg lengths per second the root covers over :data:`TRAVEL_WINDOW_S` (see the module)."""
    legs = leg_length(motion.skeleton)
    if legs <= 0 or motion.frame_count < 2:
        return 0.0
    world = motion.positions() if positions is None else positions
    root = world[:, find_root_joint(motion)][:, [0, 2]]
    lag = max(1, min(motion.frame_count - 1, round(TRAVEL_WINDOW_S / motion.frame_time)))
    covered = np.linalg.norm(root[lag:] - root[:-lag], axis=1)
    return float(np.mean(covered)) / (lag * motion.frame_time) / legs


def action_shape(motions: Sequence[Motion]) -> ActionShape:
    """What the clips of one action do: whether they travel and which limbs carry a cycle."""
    if not motions:
        return ActionShape(False, "none")
    positions = [m.positions() for m in motions]  # forward kinematics once per clip
    pairs = list(zip(motions, positions, strict=True))
    travels = float(np.median([travel_rate(m, p) for m, p in pairs])) >= TRAVEL_LEG_LENGTHS_PER_S
    if travels:
        return ActionShape(True, "steps", _median_positive([step_period(m, p) for m, p in pairs]))
    swinging = [(m, p) for m, p in pairs if swings_regularly(m, p)]
    if len(swinging) < HAND_CYCLE_SHARE * len(motions):
        return ActionShape(False, "none")
    return ActionShape(False, "hands", _median_positive([swing_period(m, p) for m, p in swinging]))


def _median_positive(values: Sequence[float]) -> float:
    positive = [v for v in values if v > 0]
    return float(np.median(positive)) if positive else 0.0

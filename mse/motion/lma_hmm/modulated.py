"""The cached result of the LMA + HMM modulation, its disk format and its timing.

:class:`Modulated` holds steps 1-5 of :mod:`mse.motion.lma_hmm.generate` for one (library,
action, style, desired path, parameters): the modulated path at the desired path's frame rate
(rotation vectors, then :data:`CARRIED` columns of how the body is carried), the states and
their means (to lengthen cyclic paths, :func:`continue_cycle`), the neighbours' state sequences.
:func:`path_for` gives the path for a clip of a requested length, :func:`save` / :func:`load`
keep it on disk (npz, no pickle, format :data:`DISK_FORMAT`).
"""

from __future__ import annotations

import io
import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from mse.fileio import write_atomic
from mse.motion.base.bvh import Skeleton
from mse.motion.base.cycles import ActionShape
from mse.motion.base.kinematics import FloatArray
from mse.motion.lma_hmm.hmm import Encoding, smooth, state_path
from mse.motion.lma_hmm.timing import resample

#: columns after the rotations in a modulated path: how the body is carried (contacts.support)
CARRIED = 4
#: a cyclic path is continued rather than slowed when the clip is this much longer than it
LOOP_RATIO = 1.3
DISK_FORMAT = "mse-lma-hmm-path/14"


@dataclass(frozen=True, eq=False)
class Modulated:
    """Cached result of steps 1-5: the modulated rotation path at the desired frame rate."""

    encoding: Encoding
    frame_time: float
    path: FloatArray  # (frames, 3 x rotated joints) rotation vectors
    height: float  # contact height of the neighbours
    neighbours: tuple[str, ...]
    components: tuple[str, ...]
    cyclic: bool
    timings: dict[str, float]
    states: npt.NDArray[np.int_]  # the desired path's Viterbi states
    means: FloatArray  # (states, dims) the states' mean rotations
    labels: tuple[npt.NDArray[np.int_], ...]  # the neighbours' Viterbi states
    cutoff_hz: float
    #: what the action's clips do (:func:`mse.motion.lma_hmm.generate.action_shape_of`): a
    #: cycling action requested longer than its path repeats its cycles (base.loop)
    shape: ActionShape
    #: turning locomotion (:func:`mse.motion.lma_hmm.generate.action_turn_of`): the path is
    #: straight (its clips straightened to their paths' heading) and the generated clip turns
    #: at this many radians per second from ``start_yaw``; 0: it goes straight as it is
    turn_rate: float = 0.0
    start_yaw: float = 0.0


def _cycling_end(labels: npt.NDArray[np.int_]) -> int:
    """Where a neighbour's cycle ends: after the last run of a state it enters more than
    once. The states after it (a run's or a dash's stop, entered once at the end of the take)
    lead nowhere: continued into them, a dataset 1 dash at 2x its length stopped and stood in
    its last state (0 steps/s, its stance foot sliding at 90 cm/s)."""
    starts = [0] + [i for i in range(1, len(labels)) if labels[i] != labels[i - 1]]
    entered: dict[int, int] = {}
    for i in starts:
        entered[int(labels[i])] = entered.get(int(labels[i]), 0) + 1
    stops = [*starts[1:], len(labels)]
    recurring = [stop for start, stop in zip(starts, stops, strict=True) if entered[int(labels[start])] > 1]
    return recurring[-1] if recurring else len(labels)


def continue_cycle(
    states: npt.NDArray[np.int_], neighbours: Sequence[npt.NDArray[np.int_]], frames: int
) -> npt.NDArray[np.int_]:
    """A cyclic state path continued to ``frames`` frames with the neighbours' own state
    sequences: from the path's last state, the rest of a neighbour's cycle (up to
    :func:`_cycling_end`) from a frame where it enters that state (the first such frame after
    its first tenth), and so on. A walk scheduled for longer than its desired path (Bandai's
    walk-back takes are one stride) takes more steps, in the neighbours' order and pace,
    instead of slower ones. (Following the most likely transition from state to state
    instead made jerky, looping gaits.)"""
    path = [int(s) for s in states]
    usable = [n for n in neighbours if len(n) > 2]
    if not path or not usable:
        return states
    ends = [_cycling_end(n) for n in usable]
    turn = 0
    while len(path) < frames:
        last = path[-1]
        extended = False
        for k in range(len(usable)):
            index = (turn + k) % len(usable)
            labels, stop = usable[index], ends[index]
            start = max(1, len(labels) // 10)
            entries = [i for i in range(start, stop - 1) if labels[i] == last and labels[i - 1] != last]
            if entries:
                tail = labels[entries[0] + 1 : stop]
                path += [int(s) for s in tail[: frames - len(path)]]
                extended = True
                turn += k + 1
                break
        if not extended:
            break
    return np.asarray(path, dtype=np.int_)


def path_for(modulated: Modulated, frames: int, loop_ratio: float = LOOP_RATIO) -> FloatArray:
    """The modulated path for a clip of ``frames`` frames at the desired frame rate: cyclic
    paths shorter than that by ``loop_ratio`` are continued by :func:`continue_cycle`,
    longer ones cut (a cycle keeps its tempo)."""
    path = modulated.path
    if modulated.cyclic and frames < len(path):
        return path[: max(frames, 2)]  # a cycle in its own tempo, cut rather than sped up
    if not modulated.cyclic or frames < loop_ratio * len(path) or len(modulated.states) != len(path):
        return path
    states = continue_cycle(modulated.states, modulated.labels, frames)
    if len(states) == len(modulated.states):
        return path
    # the cut-off of the desired path itself: the neighbours' paths switch states more often
    runs = 1 + int(np.count_nonzero(np.diff(modulated.states)))
    hz = cutoff(modulated.cutoff_hz, len(modulated.states), runs, modulated.frame_time)
    return smooth(state_path(modulated.means, states), modulated.frame_time, hz)


def cutoff(base_hz: float, frames: int, runs: int, frame_time: float) -> float:
    """The low-pass cut-off: ``base_hz``, raised to half the rate of the state path's runs
    when they are shorter than that (the filter smooths the joins between states; on a
    20-frame Bandai dash with 12 states, 3 Hz also took away half of the stride: 168 cm/s
    of travel generated from the 430 cm/s clip itself)."""
    run_rate = runs / max(frames * frame_time, 1e-9)
    return max(base_hz, 0.5 * run_rate)


def time_warp(values: FloatArray, frame_time: float, duration: float) -> tuple[FloatArray, float]:
    """Resample ``values`` linearly to last exactly ``duration`` seconds."""
    frames = max(2, round(duration / frame_time))
    if len(values) == 1:
        return np.repeat(values, frames, axis=0), duration / frames
    return resample(values, frames), duration / frames


def _shape(stored: list[object]) -> ActionShape:
    travels, cycle, period = stored
    if cycle not in ("steps", "hands", "none") or not isinstance(period, int | float):
        raise ValueError(f"bad action shape {stored!r}")
    return ActionShape(bool(travels), cycle, float(period))


def save(path: Path, modulated: Modulated) -> None:
    skeleton = modulated.encoding.skeleton
    meta = {
        "format": DISK_FORMAT,
        "names": list(skeleton.names),
        "parents": list(skeleton.parents),
        "channels": [list(c) for c in skeleton.channels],
        "end_sites": [list(e) if e is not None else None for e in skeleton.end_sites],
        "rotated": list(modulated.encoding.rotated),
        "frame_time": modulated.frame_time,
        "height": modulated.height,
        "neighbours": list(modulated.neighbours),
        "components": list(modulated.components),
        "cyclic": modulated.cyclic,
        "timings": modulated.timings,
        "cutoff_hz": modulated.cutoff_hz,
        "shape": [modulated.shape.travels, modulated.shape.cycle, modulated.shape.period_s],
        "turn": [modulated.turn_rate, modulated.start_yaw],
    }
    buffer = io.BytesIO()
    np.savez_compressed(
        buffer,
        meta=np.array(json.dumps(meta)),
        offsets=skeleton.offsets,
        references=modulated.encoding.references,
        template=modulated.encoding.template,
        path=modulated.path,
        states=modulated.states,
        means=modulated.means,
        labels=np.concatenate(modulated.labels) if modulated.labels else np.zeros(0, dtype=np.int_),
        label_lengths=np.array([len(x) for x in modulated.labels], dtype=np.int_),
    )
    write_atomic(path, buffer.getvalue())


def load(path: Path) -> Modulated | None:
    try:
        with np.load(path, allow_pickle=False) as archive:
            meta = json.loads(str(archive["meta"]))
            if meta.get("format") != DISK_FORMAT:
                return None
            skeleton = Skeleton(
                tuple(meta["names"]),
                tuple(int(p) for p in meta["parents"]),
                np.asarray(archive["offsets"], dtype=np.float64),
                tuple(tuple(c) for c in meta["channels"]),
                tuple((float(e[0]), float(e[1]), float(e[2])) if e is not None else None for e in meta["end_sites"]),
            )
            encoding = Encoding(
                skeleton,
                tuple(int(j) for j in meta["rotated"]),
                np.asarray(archive["references"], dtype=np.float64),
                np.asarray(archive["template"], dtype=np.float64),
            )
            return Modulated(
                encoding,
                float(meta["frame_time"]),
                np.asarray(archive["path"], dtype=np.float64),
                float(meta["height"]),
                tuple(meta["neighbours"]),
                tuple(meta["components"]),
                bool(meta["cyclic"]),
                {str(k): float(v) for k, v in meta["timings"].items()},
                np.asarray(archive["states"], dtype=np.int_),
                np.asarray(archive["means"], dtype=np.float64),
                tuple(
                    np.split(
                        np.asarray(archive["labels"], dtype=np.int_),
                        np.cumsum(np.asarray(archive["label_lengths"], dtype=np.int_))[:-1],
                    )
                )
                if len(archive["label_lengths"])
                else (),
                float(meta["cutoff_hz"]),
                _shape(meta["shape"]),
                float(meta["turn"][0]),
                float(meta["turn"][1]),
            )
    except (OSError, ValueError, KeyError, TypeError, IndexError):
        return None  # a stale or broken cache entry: regenerate

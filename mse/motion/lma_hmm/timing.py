"""The timing of a decoded path (docs/motion.md, "Generation", steps 6, 8, 11 and 12): each run
of a state re-timed by the neighbours' own runs (:func:`retimed`), stuck runs played by the
neighbours' sequence, changes of state the neighbours never make bridged, and the neighbours'
own frames of each state (:func:`state_aligned_frames`)."""

from __future__ import annotations

import itertools
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from mse.motion.base.kinematics import FloatArray


def _runs(states: npt.NDArray[np.int_]) -> list[tuple[int, int, int]]:
    """``(start, stop, state)`` of each run of equal states."""
    if len(states) == 0:
        return []
    changes = np.flatnonzero(np.diff(states)) + 1
    starts = np.concatenate([[0], changes]).astype(int)
    stops = np.concatenate([changes, [len(states)]]).astype(int)
    return [(int(a), int(b), int(states[a])) for a, b in zip(starts, stops, strict=True)]


#: a run of the desired path this many times longer than the neighbours' longest run of its
#: state is a decoding that lost the movement (see :func:`retimed`)
STUCK_FACTOR = 2.0


def _continued(state: int, sequence_states: Sequence[npt.NDArray[np.int_]], frames: int) -> npt.NDArray[np.int_]:
    """``frames`` frames of the neighbours' own state sequences from an entry into ``state``
    (the first after each sequence's first tenth, up to its last tenth: not their rest
    poses), one neighbour after the other; a state none of them enters there (-1: any)
    starts from a neighbour's first tenth."""
    out: list[int] = []
    current = state
    for turn in range(4 * len(sequence_states) + 4):
        if len(out) >= frames:
            break
        for k in range(len(sequence_states)):
            labels = sequence_states[(turn + k) % len(sequence_states)]
            start, stop = max(1, len(labels) // 10), len(labels) - len(labels) // 10
            entries = [
                i
                for i in range(start, stop - 1)
                if labels[i] == current and labels[i - 1] != current and np.any(labels[i:stop] != current)
            ]
            if entries:
                out += [int(x) for x in labels[entries[0] : stop][: frames - len(out)]]
                current = out[-1]
                break
        else:  # no neighbour enters that state in its movement: its middle, from the start
            labels = sequence_states[turn % len(sequence_states)]
            start, stop = max(1, len(labels) // 10), len(labels) - len(labels) // 10
            if stop - start < 2:
                break
            out += [int(x) for x in labels[start:stop][: frames - len(out)]]
            current = out[-1]
    if len(out) < frames:
        out += [current] * (frames - len(out))
    return np.asarray(out[:frames], dtype=np.int_)


def retimed(
    states: npt.NDArray[np.int_],
    sequence_states: Sequence[npt.NDArray[np.int_]],
    *,
    refill_stuck: bool = False,
    bridge: bool | None = None,
) -> npt.NDArray[np.int_]:
    """The desired path's state order with the neighbours' timing: each run of state s
    lasts the mean length of the runs of s in the neighbours' own Viterbi sequences, in
    whole frames with the rounding carried to the next run (a state they never visit keeps
    its run). The desired path's Viterbi runs carry its own
    tempo: a chimpira guide drawn from a normal one raced through 46 states of the
    chimpira's 186-frame gesture in 2-frame runs (jerk 6x the real clip's), a masculine
    wave from a normal one swung at the normal wave's rate with a 2 cm amplitude.

    ``refill_stuck``: a run more than :data:`STUCK_FACTOR` times longer than the neighbours'
    longest run of its state (the decoding found no state for the desired movement and sat
    in a broad one: a youthful wave decoded against elderly waves sat 23 frames in one
    state, and retimed, the wave was gone) keeps its length and is played by the
    neighbours' own state sequence from that state; and a change of state the neighbours
    never make goes through the states by which they do (:func:`_bridged`; ``bridge``
    alone, without ``refill_stuck``, when given)."""
    lengths: dict[int, list[int]] = {}
    for labels in sequence_states:
        for start, stop, state in _runs(labels):
            lengths.setdefault(state, []).append(stop - start)
    out = []
    runs = _runs(states)
    # the rounding to whole frames carried from run to run: rounded one by one, a feminine
    # walk's runs of 2.2-2.4 frames on average became 2, and its cycle 31 frames where the
    # neighbours' means add up to 33.3 (1.93 steps/s against their 1.76-1.90)
    carried = 0.0
    for index, (start, stop, state) in enumerate(runs):
        own = lengths.get(state)
        if refill_stuck and own and stop - start > STUCK_FACTOR * max(own):
            # from the state before (or, at the start, after) the stuck run: the stuck state
            # is often a rest pose, which the neighbours only enter at their ends
            around = runs[index - 1][2] if index > 0 else runs[index + 1][2] if index + 1 < len(runs) else -1
            out.append(_continued(around, sequence_states, stop - start))
            continue
        if not own:
            out.append(np.full(stop - start, state, dtype=np.int_))
            continue
        mean = float(np.mean(own))
        length = max(1, round(mean + carried))
        carried += mean - length
        out.append(np.full(length, state, dtype=np.int_))
    if not out:
        return states.copy()
    path = np.concatenate(out)
    return _bridged(path, sequence_states, lengths) if (refill_stuck if bridge is None else bridge) else path


def _bridged(
    path: npt.NDArray[np.int_], sequence_states: Sequence[npt.NDArray[np.int_]], lengths: dict[int, list[int]]
) -> npt.NDArray[np.int_]:
    """``path`` where every change of state the neighbours never make goes through the
    states by which they do (the fewest, breadth-first over their own changes), each for its
    mean run: a normal wave decoded against masculine ones went from the rest pose straight
    to the middle of a swing in 4 frames (hand jerk 1.5x the limit)."""
    moves: dict[int, set[int]] = {}
    for labels in sequence_states:
        for a, b in itertools.pairwise(labels):
            if a != b:
                moves.setdefault(int(a), set()).add(int(b))
    runs = _runs(path)
    out = [path[runs[0][0] : runs[0][1]]] if runs else []
    for (_, _, before), (start, stop, after) in itertools.pairwise(runs):
        if after not in moves.get(before, set()):
            for state in _shortest(before, after, moves)[1:-1]:
                out.append(np.full(max(1, round(float(np.mean(lengths[state])))), state, dtype=np.int_))
        out.append(path[start:stop])
    return np.concatenate(out) if out else path


def _shortest(start: int, goal: int, moves: dict[int, set[int]]) -> list[int]:
    """The fewest states from ``start`` to ``goal`` along ``moves`` ([start, goal] if none)."""
    previous: dict[int, int] = {start: start}
    frontier = [start]
    while frontier and goal not in previous:
        following = []
        for state in frontier:
            for nxt in sorted(moves.get(state, ())):
                if nxt not in previous:
                    previous[nxt] = state
                    following.append(nxt)
        frontier = following
    if goal not in previous:
        return [start, goal]
    chain = [goal]
    while chain[-1] != start:
        chain.append(previous[chain[-1]])
    return chain[::-1]


def resample(segment: FloatArray, frames: int) -> FloatArray:
    """Linear resampling of (n, dims) to (frames, dims)."""
    if len(segment) == frames:
        return segment.copy()
    if len(segment) == 1 or frames == 1:
        return np.repeat(segment[len(segment) // 2 : len(segment) // 2 + 1], frames, axis=0)
    source = np.linspace(0.0, 1.0, len(segment))
    target = np.linspace(0.0, 1.0, frames)
    out = np.empty((frames, segment.shape[1]))
    for dim in range(segment.shape[1]):
        out[:, dim] = np.interp(target, source, segment[:, dim])
    return out


def state_aligned_frames(
    states: npt.NDArray[np.int_],
    means: FloatArray,
    sequences: Sequence[FloatArray],
    sequence_states: Sequence[npt.NDArray[np.int_]],
) -> FloatArray:
    """The training frames themselves in the desired path's state order and timing.

    Each run of state s in ``states`` (the desired path's Viterbi sequence) is replaced by
    the run of s in the training sequences (the neighbours, by their own Viterbi sequences)
    that sits at the closest relative time, linearly resampled to the run's length; a state
    no training sequence visits gives its mean. Unlike the state means this keeps the target
    style's movement *within* a state (speed, curvature), which the means average away."""
    pool: dict[int, list[tuple[float, FloatArray]]] = {}
    for sequence, labels in zip(sequences, sequence_states, strict=True):
        for start, stop, state in _runs(labels):
            centre = 0.5 * (start + stop) / len(labels)
            pool.setdefault(state, []).append((centre, sequence[start:stop]))
    out = np.empty((len(states), means.shape[1]))
    for start, stop, state in _runs(states):
        centre = 0.5 * (start + stop) / len(states)
        candidates = pool.get(state)
        if not candidates:
            out[start:stop] = means[state]
            continue
        _, segment = min(candidates, key=lambda item: abs(item[0] - centre))
        out[start:stop] = resample(segment, stop - start)
    return out

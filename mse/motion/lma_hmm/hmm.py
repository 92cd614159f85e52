"""Observations for the HMM and the HMM_NN step of the paper's Fig. 2.

Observations are joint *rotations* (rotation vectors relative to the desired path's mean
rotation of each joint) plus the position channels that vary (the root's), taken relative to
the clip's first frame in the floor plane. Constant channels (e.g. Bandai's
bone-offset position channels) are not modelled: they are copied from the desired path, so
forward kinematics on the result keeps the skeleton's bone lengths.

HMM (hmmlearn ``GaussianHMM``): fully connected, full covariances, ``states`` states (12 by
default, fewer when the data are shorter); means and covariances initialised from equal time
segments of the training sequences; start and transition probabilities set uniform by hand
(``init_params=""``: hmmlearn's random start can draw zeros that never recover); an identity
covariance prior with weight dimension + 2 on z-scored observations, so that one neighbour
does not make covariances singular; BLAS limited to one thread while fitting.

Regeneration: :func:`state_path` (the paper's sequence of state means, with ramps) or
:func:`state_aligned_frames` (the neighbours' own frames of each state, in the desired path's
state order and timing).
"""

from __future__ import annotations

import logging
import os
import warnings
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from mse.motion.base.bvh import Motion, Skeleton
from mse.motion.base.filters import zero_phase_lowpass
from mse.motion.base.kinematics import (
    FloatArray,
    matrix_to_euler,
    mean_rotation,
    rotation_exp,
    rotation_log,
)

_VARYING = 1e-6


@dataclass(frozen=True, eq=False)
class Encoding:
    """Which channels the HMM sees, and how to map observations back to channel values.

    Rotations are encoded as rotation vectors relative to a per-joint reference (the desired
    path's mean rotation): continuous, unlike Euler angles near gimbal lock (Bandai's bones
    lie along X, so its ZXY middle angles sit near 90 degrees).
    """

    skeleton: Skeleton
    rotated: tuple[int, ...]  # joints with three rotation channels
    references: FloatArray  # (len(rotated), 3, 3)
    positions: tuple[int, ...]  # varying position channels that are modelled
    floor_root: tuple[int, ...]  # of those, the ones taken relative to the first frame
    template: FloatArray  # (channels,) values of the unmodelled channels

    @property
    def dimension(self) -> int:
        return 3 * len(self.rotated) + len(self.positions)


def encoding_for(skeleton: Skeleton, sequences: Sequence[Motion], desired: Motion) -> Encoding:
    pooled = np.vstack([m.values for m in sequences] + [desired.values])
    rotated = tuple(j for j in range(skeleton.joint_count) if len(skeleton.rotation_order(j)) == 3)
    local = desired.local_rotations()
    references = np.array([mean_rotation(local[:, j]) for j in rotated]).reshape(-1, 3, 3)
    positions = tuple(
        c
        for j in range(skeleton.joint_count)
        for c in skeleton.position_columns(j)
        if float(pooled[:, c].std()) > _VARYING
    )
    floor: list[int] = []
    for joint in range(skeleton.joint_count):
        columns = skeleton.position_columns(joint)
        if columns and columns[0] in positions:
            floor += [columns[0], columns[2]]  # X and Z: Y is up
    return Encoding(skeleton, rotated, references, positions, tuple(floor), desired.values.mean(axis=0))


def encode(encoding: Encoding, motion: Motion) -> FloatArray:
    """(frames, dims) observations: rotation vectors, then the modelled positions."""
    local = motion.local_rotations()[:, list(encoding.rotated)]
    relative = np.swapaxes(encoding.references, -1, -2)[None] @ local
    vectors = rotation_log(relative).reshape(motion.frame_count, -1)
    positions = motion.values[:, list(encoding.positions)].copy()
    for k, column in enumerate(encoding.positions):
        if column in encoding.floor_root:
            positions[:, k] -= positions[0, k]
    return np.hstack([vectors, positions])


def decode(encoding: Encoding, observations: FloatArray, origin: FloatArray) -> FloatArray:
    """Channel values (frames, channels) from observations; ``origin``: the desired path's
    first-frame values, to put the root back where the desired path starts."""
    frames = len(observations)
    values = np.tile(encoding.template, (frames, 1))
    count = len(encoding.rotated)
    vectors = observations[:, : 3 * count].reshape(frames, count, 3)
    matrices = encoding.references[None] @ rotation_exp(vectors)
    skeleton = encoding.skeleton
    for k, joint in enumerate(encoding.rotated):
        angles = matrix_to_euler(matrices[:, k], skeleton.rotation_order(joint))
        values[:, list(skeleton.rotation_columns(joint))] = angles
    for k, column in enumerate(encoding.positions):
        values[:, column] = observations[:, 3 * count + k]
        if column in encoding.floor_root:
            values[:, column] += origin[column]
    return values


@contextmanager
def single_thread_blas() -> Iterator[None]:
    """Pin BLAS to one thread (threadpoolctl when present, else environment variables)."""
    try:
        from threadpoolctl import threadpool_limits  # type: ignore[import-untyped]
    except ImportError:  # pragma: no cover - threadpoolctl ships with scikit-learn
        names = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
        saved = {n: os.environ.get(n) for n in names}
        os.environ.update({n: "1" for n in names})
        try:
            yield
        finally:
            for name, value in saved.items():
                if value is None:
                    os.environ.pop(name, None)
                else:
                    os.environ[name] = value
        return
    with threadpool_limits(limits=1):
        yield


@dataclass(frozen=True, eq=False)
class TrainedHmm:
    means: FloatArray  # (states, dims) in observation units
    model: object | None  # hmmlearn GaussianHMM on the z-scored active dimensions
    active: tuple[int, ...]  # dimensions that vary in the training data
    mean: FloatArray
    scale: FloatArray
    converged: bool

    def viterbi(self, observations: FloatArray) -> FloatArray:
        """Most likely state sequence of ``observations`` (as float indices)."""
        if self.model is None:
            return np.zeros(len(observations))
        columns = list(self.active)
        z = (observations[:, columns] - self.mean[columns]) / self.scale[columns]
        _, states = self.model.decode(z, algorithm="viterbi")  # type: ignore[attr-defined]
        return np.asarray(states, dtype=np.float64)


def _segment_init(sequences: Sequence[FloatArray], states: int) -> tuple[FloatArray, FloatArray]:
    dims = sequences[0].shape[1]
    pooled: list[list[FloatArray]] = [[] for _ in range(states)]
    for sequence in sequences:
        for state, segment in enumerate(np.array_split(sequence, states)):
            if len(segment):
                pooled[state].append(segment)
    everything = np.vstack(sequences)
    global_cov = np.cov(everything, rowvar=False, bias=True).reshape(dims, dims)
    means = np.empty((states, dims))
    covars = np.empty((states, dims, dims))
    for state in range(states):
        frames = np.vstack(pooled[state]) if pooled[state] else everything
        means[state] = frames.mean(axis=0)
        n = len(frames)
        cov = np.cov(frames, rowvar=False, bias=True).reshape(dims, dims) if n > 1 else 0.0
        # shrink towards the global covariance and the identity prior: never singular
        covars[state] = (n * cov + 2.0 * global_cov + np.eye(dims)) / (n + 3.0)
    return means, covars


def train_hmm(
    sequences: Sequence[FloatArray],
    states: int,
    *,
    n_iter: int = 8,
    seed: int = 0,
    also_scale: FloatArray | None = None,
    prior_frames: float | None = None,
) -> TrainedHmm:
    """Fit the HMM_NN on ``sequences`` (each frames x dims).

    Observations are z-scored over the sequences (plus ``also_scale``, the desired path, so
    that its offsets from the neighbours do not look like outliers); the identity covariance
    prior weighs ``prior_frames`` frames (default: the mean frames per state).
    """
    from hmmlearn.hmm import GaussianHMM

    pooled = np.vstack(sequences)
    scaling = pooled if also_scale is None else np.vstack([pooled, also_scale])
    mean = scaling.mean(axis=0)
    scale = scaling.std(axis=0)
    # constant dimensions are left out: with a covariance prior they would reward the states
    # with the most frames (smaller prior share) and collapse EM onto one state
    active = tuple(int(d) for d in np.flatnonzero(pooled.std(axis=0) > 1e-7))
    scale[scale < 1e-9] = 1.0
    if not active:
        return TrainedHmm(pooled.mean(axis=0)[None, :], None, (), mean, scale, True)
    columns = list(active)
    dims = len(columns)
    z_sequences = [(s[:, columns] - mean[columns]) / scale[columns] for s in sequences]
    shortest = min(len(s) for s in sequences)
    states = max(1, min(states, len(pooled) // 3, max(2, shortest)))
    init_means, init_covars = _segment_init(z_sequences, states)
    kappa = max(2.0, prior_frames if prior_frames is not None else len(pooled) / states)
    model = GaussianHMM(
        n_components=states,
        covariance_type="full",
        covars_prior=kappa * np.eye(dims),
        covars_weight=dims + kappa,
        n_iter=n_iter,
        tol=1e-2,
        init_params="",
        params="stmc",
        random_state=seed,
        implementation="log",
    )
    uniform_start, uniform_transitions = np.full(states, 1.0 / states), np.full((states, states), 1.0 / states)
    model.startprob_, model.transmat_ = uniform_start, uniform_transitions
    model.means_, model.covars_ = init_means, init_covars
    converged = False
    # hmmlearn logs a warning whenever the prior makes the (prior-free) likelihood drop
    logger = logging.getLogger("hmmlearn")
    level = logger.level
    logger.setLevel(logging.ERROR)
    with single_thread_blas(), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            model.fit(np.vstack(z_sequences), [len(s) for s in z_sequences])
            converged = bool(model.monitor_.converged)
        except (ValueError, np.linalg.LinAlgError):
            pass  # degenerate data: the segment initialisation below is a valid model
        finally:
            logger.setLevel(level)
    if not all(np.all(np.isfinite(x)) for x in (model.means_, model.transmat_, model.startprob_)):
        model.startprob_, model.transmat_ = uniform_start, uniform_transitions
        model.means_, model.covars_ = init_means, init_covars
    means = np.tile(mean, (states, 1))
    means[:, columns] = np.asarray(model.means_, dtype=np.float64) * scale[columns] + mean[columns]
    return TrainedHmm(means, model, active, mean, scale, converged)


def smooth(sequence: FloatArray, frame_time: float, cutoff_hz: float = 3.0) -> FloatArray:
    """Zero-phase low-pass filter along time (Butterworth order 2, forwards and backwards:
    ``scipy.signal.filtfilt``'s result, computed by :mod:`mse.motion.base.filters`)."""
    return zero_phase_lowpass(sequence, frame_time, cutoff_hz)


def state_path(means: FloatArray, states: npt.NDArray[np.int_]) -> FloatArray:
    """The sequence of state means, each run of a state replaced by a linear ramp between
    the runs' midpoints (a first low-pass stage: no steps at state changes)."""
    frames = len(states)
    if frames == 0:
        return np.empty((0, means.shape[1]))
    changes = np.flatnonzero(np.diff(states)) + 1
    starts = np.concatenate([[0], changes])
    stops = np.concatenate([changes, [frames]])
    if len(starts) == 1:
        return np.repeat(means[states[:1]], frames, axis=0)
    anchors_t = np.concatenate([[0.0], (starts + stops - 1) / 2.0, [frames - 1.0]])
    anchors = means[np.concatenate([[states[0]], states[starts], [states[-1]]])]
    times = np.arange(frames, dtype=np.float64)
    path = np.empty((frames, means.shape[1]))
    for dim in range(means.shape[1]):
        path[:, dim] = np.interp(times, anchors_t, anchors[:, dim])
    return path


def _runs(states: npt.NDArray[np.int_]) -> list[tuple[int, int, int]]:
    """``(start, stop, state)`` of each run of equal states."""
    if len(states) == 0:
        return []
    changes = np.flatnonzero(np.diff(states)) + 1
    starts = np.concatenate([[0], changes]).astype(int)
    stops = np.concatenate([changes, [len(states)]]).astype(int)
    return [(int(a), int(b), int(states[a])) for a, b in zip(starts, stops, strict=True)]


def _resample(segment: FloatArray, frames: int) -> FloatArray:
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
        out[start:stop] = _resample(segment, stop - start)
    return out

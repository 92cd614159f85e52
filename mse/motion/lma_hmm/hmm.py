"""HMM_NN of the paper's Fig. 2: states, Viterbi of the desired path, regeneration.

Two spaces:

- **phases** (:mod:`mse.motion.lma_hmm.pose`): the HMM is trained and decoded on the
  neighbours' body-frame poses, each clip z-scored by itself;
- **rotations** (:class:`Encoding`): every state also has the mean of the neighbours' joint
  rotations (rotation vectors relative to the desired path's mean rotation of each joint),
  weighted by the state posteriors; the generated path is made of those, so bone lengths
  are kept and the style's posture comes from the neighbours. Euler angles are never
  averaged (Bandai's bones lie along X, its ZXY middle angle sits near 90 degrees).

HMM (hmmlearn ``GaussianHMM``, diagonal covariances on the decorrelated phase components):

- ``topology="full"``: fully connected as in the paper, means initialised by k-means on the
  pooled frames (equal time segments make a walk's states slices of time instead of phases
  of a step), start probabilities learned from the neighbours' first frames (the paper's
  π₁ = 1 for clips that share a start pose, when they do);
- ``topology="left-to-right"``: each state goes to itself or the next, the first state
  starts and Viterbi ends in the last one: the desired path goes through every phase of
  the neighbours in order; the chain has at least one state per
  :data:`FRAMES_PER_CHAIN_STATE` frames (a sharp movement is not averaged away);
- ``topology="auto"`` (default): fully connected when the neighbours *cycle* (their own
  Viterbi paths under the fully connected model re-enter states: at least
  :data:`CYCLIC_RUNS_PER_STATE` runs per visited state, as steps and waves do; clips of
  fewer than :data:`CYCLIC_FRAMES_PER_STATE` frames per state, such as Bandai's one-stride
  dashes, cannot show it and are left-to-right), else left-to-right. Measured on Bandai:
  fully connected models of one-shot actions let the desired path skip the neighbour's key
  phase (an angry bow generated from a normal one kept the head within 0.5 cm where real
  bows dip 14 cm).

Regeneration: :func:`state_path` (the paper's sequence of state means, with ramps) or
:func:`~mse.motion.lma_hmm.timing.state_aligned_frames` (the neighbours' own frames of each
state); the timing of the path's runs is :mod:`mse.motion.lma_hmm.timing`'s.
"""

from __future__ import annotations

import contextlib
import logging
import os
import warnings
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Literal, get_args

import numpy as np
import numpy.typing as npt

from mse.extras import require
from mse.motion.base.bvh import Motion, Skeleton
from mse.motion.base.filters import zero_phase_lowpass
from mse.motion.base.kinematics import FloatArray, matrix_to_euler, mean_rotation, rotation_exp, rotation_log

#: the HMM's topology: "auto" (fully connected when the neighbours cycle, else
#: left-to-right), "full" (the paper's), "left-to-right"
Topology = Literal["auto", "full", "left-to-right"]
TOPOLOGIES: tuple[Topology, ...] = get_args(Topology)
#: neighbours whose Viterbi paths have at least this many runs per visited state cycle
#: (Bandai clips decoded by their own 12-state model: bows 1.0-2.2, guide 1.1-2.0, raising
#: both hands 1.1-1.9; walks 4.6-12.9, runs 2.5-6.1, waving both hands 2.3-9.7)
CYCLIC_RUNS_PER_STATE = 2.25
#: ... when they are long enough to repeat anything: this many frames per state on average
CYCLIC_FRAMES_PER_STATE = 4
#: a left-to-right chain has at least one state per this many frames of the neighbours'
#: median length (12 states drew a 90-frame angry bow, whose dip lasts 5 frames, through
#: 7-frame averages: 5 cm of its 14 cm dip survived; one state per 4 frames kept it)
FRAMES_PER_CHAIN_STATE = 4
_MIN_COVAR = 1e-3


@dataclass(frozen=True, eq=False)
class Encoding:
    """Rotation channels as rotation vectors relative to per-joint references; every other
    channel is copied from ``template`` (bone offsets; the root is placed afterwards)."""

    skeleton: Skeleton
    rotated: tuple[int, ...]  # joints with three rotation channels
    references: FloatArray  # (len(rotated), 3, 3)
    template: FloatArray  # (channels,)

    @property
    def dimension(self) -> int:
        return 3 * len(self.rotated)


def encoding_for(desired: Motion) -> Encoding:
    skeleton = desired.skeleton
    rotated = tuple(j for j in range(skeleton.joint_count) if len(skeleton.rotation_order(j)) == 3)
    local = desired.local_rotations()
    references = np.array([mean_rotation(local[:, j]) for j in rotated]).reshape(-1, 3, 3)
    return Encoding(skeleton, rotated, references, desired.values.mean(axis=0))


def encode(encoding: Encoding, motion: Motion) -> FloatArray:
    """(frames, 3 x rotated joints) rotation vectors relative to the references."""
    local = motion.local_rotations()[:, list(encoding.rotated)]
    relative = np.swapaxes(encoding.references, -1, -2)[None] @ local
    result: FloatArray = rotation_log(relative).reshape(motion.frame_count, -1)
    return result


def decode(encoding: Encoding, observations: FloatArray) -> FloatArray:
    """Channel values (frames, channels) from rotation vectors."""
    frames = len(observations)
    values = np.tile(encoding.template, (frames, 1))
    count = len(encoding.rotated)
    vectors = observations[:, : 3 * count].reshape(frames, count, 3)
    matrices = encoding.references[None] @ rotation_exp(vectors)
    skeleton = encoding.skeleton
    for k, joint in enumerate(encoding.rotated):
        angles = matrix_to_euler(matrices[:, k], skeleton.rotation_order(joint))
        values[:, list(skeleton.rotation_columns(joint))] = angles
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
    model: object | None  # hmmlearn GaussianHMM on the phase observations; None: one state
    states: int
    cyclic: bool

    @property
    def transitions(self) -> FloatArray:
        """(states, states) transition probabilities."""
        if self.model is None:
            return np.ones((1, 1))
        result: FloatArray = np.asarray(self.model.transmat_, dtype=np.float64)  # type: ignore[attr-defined]
        return result

    def log_likelihoods(self, observations: FloatArray) -> FloatArray:
        """(frames, states) log densities of every frame under every state."""
        if self.model is None:
            return np.zeros((len(observations), 1))
        result: FloatArray = self.model._compute_log_likelihood(observations)  # type: ignore[attr-defined]
        return result

    def posteriors(self, observations: FloatArray) -> FloatArray:
        if self.model is None or len(observations) == 0:
            return np.ones((len(observations), 1))
        result: FloatArray = self.model.predict_proba(observations)  # type: ignore[attr-defined]
        return result

    def viterbi(self, observations: FloatArray) -> npt.NDArray[np.int_]:
        """Most likely state sequence; a left-to-right model starts in the first state and
        ends in the last one (when the sequence is long enough to reach it)."""
        if self.model is None or len(observations) == 0:
            return np.zeros(len(observations), dtype=np.int_)
        model = self.model
        with np.errstate(divide="ignore"):
            transitions = np.log(model.transmat_)  # type: ignore[attr-defined]
            start = np.log(model.startprob_)  # type: ignore[attr-defined]
        end = self.states - 1 if not self.cyclic and len(observations) >= self.states else None
        return viterbi(self.log_likelihoods(observations), transitions, start, end)


def viterbi(
    loglik: FloatArray, transitions: FloatArray, start: FloatArray, end: int | None = None
) -> npt.NDArray[np.int_]:
    """Viterbi path of (frames, states) log likelihoods; ``end`` forces the last state."""
    frames, states = loglik.shape
    score = start + loglik[0]
    back = np.zeros((frames, states), dtype=np.int_)
    columns = np.arange(states)
    for t in range(1, frames):
        candidates = score[:, None] + transitions
        back[t] = np.argmax(candidates, axis=0)
        score = candidates[back[t], columns] + loglik[t]
    last = end if end is not None and np.isfinite(score[end]) else int(np.argmax(score))
    path = np.empty(frames, dtype=np.int_)
    path[-1] = last
    for t in range(frames - 1, 0, -1):
        path[t - 1] = back[t, path[t]]
    return path


def _left_to_right(states: int) -> FloatArray:
    transitions = np.zeros((states, states))
    for state in range(states - 1):
        transitions[state, state] = transitions[state, state + 1] = 0.5
    transitions[-1, -1] = 1.0
    return transitions


def _segment_means(sequences: Sequence[FloatArray], states: int) -> FloatArray:
    parts = [np.array_split(s, states) for s in sequences]
    pooled = np.vstack(sequences)
    means = np.tile(pooled.mean(axis=0), (states, 1))
    for k in range(states):
        chunks = [p[k] for p in parts if len(p[k])]
        if chunks:
            means[k] = np.vstack(chunks).mean(axis=0)
    return means


def _kmeans_means(sequences: Sequence[FloatArray], states: int, seed: int) -> FloatArray:
    """k-means centres of the pooled frames, ordered by their mean relative time."""
    with require("motion"):
        from sklearn.cluster import KMeans

    pooled = np.vstack(sequences)
    times = np.concatenate([np.linspace(0.0, 1.0, len(s)) for s in sequences])
    fitted = KMeans(states, n_init=3, random_state=seed).fit(pooled)
    labels = fitted.labels_
    order = np.argsort([times[labels == k].mean() if np.any(labels == k) else 2.0 for k in range(states)])
    centres: FloatArray = fitted.cluster_centers_[order]
    return centres


def _fit(sequences: Sequence[FloatArray], states: int, cyclic: bool, n_iter: int, seed: int) -> object:
    with require("motion"):
        from hmmlearn.hmm import GaussianHMM

    pooled = np.vstack(sequences)
    model = GaussianHMM(
        n_components=states,
        covariance_type="diag",
        min_covar=_MIN_COVAR,
        n_iter=n_iter,
        tol=1e-2,
        init_params="",
        params="stmc" if cyclic else "tmc",
        random_state=seed,
        implementation="log",
    )
    if cyclic:
        model.startprob_ = np.full(states, 1.0 / states)
        model.transmat_ = np.full((states, states), 1.0 / states)
        model.means_ = _kmeans_means(sequences, states, seed)
    else:
        model.startprob_ = np.eye(states)[0]
        model.transmat_ = _left_to_right(states)
        model.means_ = _segment_means(sequences, states)
    model.n_features = pooled.shape[1]
    model.covars_ = np.tile(np.maximum(pooled.var(axis=0), _MIN_COVAR), (states, 1))
    logger = logging.getLogger("hmmlearn")
    level = logger.level
    logger.setLevel(logging.ERROR)  # hmmlearn warns about states that EM leaves empty
    try:
        with single_thread_blas(), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            snapshot = (model.startprob_.copy(), model.transmat_.copy(), model.means_.copy(), model._covars_.copy())
            with contextlib.suppress(ValueError, np.linalg.LinAlgError):  # degenerate data
                model.fit(pooled, [len(s) for s in sequences])
            finite = all(
                np.all(np.isfinite(x)) for x in (model.startprob_, model.transmat_, model.means_, model._covars_)
            )
            rows = np.asarray(model.transmat_).sum(axis=1)
            if not finite or not np.allclose(rows, 1.0) or not np.isclose(np.sum(model.startprob_), 1.0):
                model.startprob_, model.transmat_, model.means_, model._covars_ = snapshot
    finally:
        logger.setLevel(level)
    return model


def runs_per_state(path: npt.NDArray[np.int_]) -> float:
    """Runs of equal states per distinct state visited (1 for a path that never returns)."""
    if len(path) == 0:
        return 1.0
    runs = 1 + int(np.count_nonzero(np.diff(path)))
    return runs / len(set(path.tolist()))


def train_hmm(
    sequences: Sequence[FloatArray],
    states: int,
    *,
    topology: Topology = "auto",
    n_iter: int = 10,
    seed: int = 0,
    decide_on: int | None = None,
) -> TrainedHmm:
    """Fit the HMM_NN on phase observations (each frames x k); ``decide_on``: how many of
    the first sequences are the neighbours whose paths decide the topology (default all)."""
    if topology not in TOPOLOGIES:
        raise ValueError(f"topology must be one of {', '.join(TOPOLOGIES)}, not {topology!r}")
    pooled = np.vstack(sequences)
    shortest = min(len(s) for s in sequences)
    states = max(1, min(states, len(pooled) // 3, max(1, shortest)))
    if states < 2:
        return TrainedHmm(None, 1, False)
    judged = sequences[: decide_on or len(sequences)]
    typical = float(np.median([len(s) for s in judged]))
    chain = int(max(states, min(shortest, round(typical / FRAMES_PER_CHAIN_STATE))))
    short = typical < CYCLIC_FRAMES_PER_STATE * states
    if topology == "left-to-right" or (topology == "auto" and short):
        return TrainedHmm(_fit(sequences, chain, False, n_iter, seed), chain, False)
    full = TrainedHmm(_fit(sequences, states, True, n_iter, seed), states, True)
    if topology == "full":
        return full
    cycling = float(np.mean([runs_per_state(full.viterbi(s)) for s in judged]))
    if cycling >= CYCLIC_RUNS_PER_STATE:
        return full
    return TrainedHmm(_fit(sequences, chain, False, n_iter, seed), chain, False)


def state_means(trained: TrainedHmm, phases: Sequence[FloatArray], values: Sequence[FloatArray]) -> FloatArray:
    """(states, dims): every state's mean of ``values`` (rotations), weighted by the state
    posteriors of the matching ``phases``; a state without weight gets the overall mean."""
    weights = np.vstack([trained.posteriors(p) for p in phases])
    stacked = np.vstack(values)
    mass = weights.sum(axis=0)
    means = (weights.T @ stacked) / np.maximum(mass[:, None], 1e-12)
    empty = mass < 1e-9
    means[empty] = stacked.mean(axis=0)
    result: FloatArray = means
    return result


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

"""Affective motion generation: the paper's Fig. 2 (RMLR + LMA neighbours + HMM/Viterbi).

``generate_motion(library, action, style, duration=...)``:

1. the desired path X_d is the leaf's ``clip`` (a library clip id) or, by default, the
   action's ``normal`` clip (else its first clip); its own style is the original emotion;
2. LMA features of the clips (cached), RMLR saliency (cached) -> the affectively
   non-discriminative components for (original, target) (eq. 12);
3. the ε-neighbourhood of X_d among the target-style clips of the same action, at least one;
4. HMM_NN trained on the neighbours plus ``nd`` copies of X_d (:mod:`mse.motion.lma_hmm.hmm`);
5. Viterbi state sequence of X_d (moved onto the neighbours' mean posture and spread first),
   sequence of state means (ramps between the midpoints of state runs), zero-phase low-pass
   filter (Butterworth, 3 Hz); ``GenerationParams(regenerate="frames")`` instead plays the
   neighbours' own frames of each state in X_d's state order and timing
   (:func:`mse.motion.lma_hmm.hmm.state_aligned_frames`);
6. time-warp (linear resampling) to the requested duration: the frame count is
   ``round(duration / frame_time)`` and the frame time is adjusted so that the clip lasts
   exactly ``duration``.

Steps 1-5 are cached per (library fingerprint, action, style, desired clip, parameters), so a
repeated leaf costs only the time-warp. Rotations are generated, never positions, so the
bone lengths of the desired path's skeleton are preserved.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from mse.diagnostics import Diagnostic, MseError, Span
from mse.motion.base.bvh import Motion, Skeleton
from mse.motion.base.kinematics import FloatArray
from mse.motion.base.library import Clip, MotionLibrary
from mse.motion.base.lma import FEATURE_NAMES
from mse.motion.lma_hmm.hmm import (
    Encoding,
    decode,
    encode,
    encoding_for,
    smooth,
    state_aligned_frames,
    state_path,
    train_hmm,
)
from mse.motion.lma_hmm.search import (
    EPSILON_FRACTION,
    clip_features,
    feature_table,
    nearest_neighbours,
    saliency_for,
)


class MotionUnavailable(Exception):
    """The library has no clip for this action (or style); callers may fall back."""


@dataclass(frozen=True, slots=True)
class GenerationParams:
    states: int = 12
    nd: int = 0
    epsilon_fraction: float = EPSILON_FRACTION
    cutoff_hz: float = 3.0
    n_iter: int = 8
    #: "means": the paper's sequence of state means; "frames": the neighbours' own frames of
    #: each state in the desired path's state order and timing (keeps within-state motion)
    regenerate: str = "means"

    def __post_init__(self) -> None:
        if self.regenerate not in ("means", "frames"):
            raise ValueError(f"regenerate must be 'means' or 'frames', not {self.regenerate!r}")


@dataclass(frozen=True, eq=False)
class _Modulated:
    """Cached result of steps 1-5: the modulated path at the desired path's frame rate."""

    skeleton: Skeleton
    frame_time: float
    values: FloatArray
    neighbours: tuple[str, ...]
    components: tuple[str, ...]
    timings: dict[str, float]


@dataclass(frozen=True, eq=False)
class Generated:
    motion: Motion
    action: str
    style: str
    desired: str
    neighbours: tuple[str, ...]
    search_components: tuple[str, ...]
    timings: dict[str, float] = field(default_factory=dict)
    cached: bool = False


_CACHE: dict[tuple[object, ...], _Modulated] = {}


def clear_cache() -> None:
    _CACHE.clear()


def _pick_desired(library: MotionLibrary, action: str, clip_id: str | None) -> Clip:
    if clip_id is not None:
        clip = library.clip(clip_id)
        if clip is None:
            raise MseError([Diagnostic("E213", f"clip {clip_id!r} is not in the library", Span("<motion>"))])
        return clip
    clips = library.select(action)
    normal = [c for c in clips if c.style == "normal"]
    return (normal or clips)[0]


def _rmlr_clips(library: MotionLibrary, action: str, exclude: set[str]) -> list[Clip]:
    """The action's clips when every style there has two or more, else the whole library."""
    own = [c for c in library.select(action) if c.id not in exclude]
    styles = [c.style for c in own]
    if len(set(styles)) >= 2 and min(styles.count(s) for s in set(styles)) >= 2:
        return own
    return [c for c in library.clips if c.id not in exclude]


def _modulate(
    library: MotionLibrary,
    action: str,
    style: str,
    desired_clip: Clip,
    original: str | None,
    params: GenerationParams,
    exclude: set[str],
) -> _Modulated:
    timings: dict[str, float] = {}
    clock = time.perf_counter()
    desired = library.motion(desired_clip)
    candidates = [
        c
        for c in library.select(action, style)
        if c.id not in exclude and c.id != desired_clip.id and library.motion(c).skeleton.same_layout(desired.skeleton)
    ]
    if not candidates:
        if desired_clip.style != style:
            raise MotionUnavailable(f"no {style!r} clip of action {action!r}")
        candidates = [desired_clip]
    desired_features = clip_features(library, desired_clip)
    candidate_features = feature_table(library, candidates)
    training = _rmlr_clips(library, action, exclude)
    feature_table(library, training)
    timings["lma"] = time.perf_counter() - clock

    clock = time.perf_counter()
    saliency = saliency_for(library, training)
    components = saliency.search_components(style, original)
    timings["rmlr"] = time.perf_counter() - clock

    clock = time.perf_counter()
    chosen = nearest_neighbours(desired_features, candidate_features, components, saliency, params.epsilon_fraction)
    neighbours = [candidates[i] for i in chosen]
    timings["nn_search"] = time.perf_counter() - clock

    clock = time.perf_counter()
    neighbour_motions = [library.motion(c) for c in neighbours]
    encoding = encoding_for(desired.skeleton, neighbour_motions, desired)
    values = _hmm_path(encoding, desired, neighbour_motions, params, timings)
    timings["filter"] = time.perf_counter() - clock - timings["hmm_fit"] - timings["viterbi"]
    return _Modulated(
        desired.skeleton,
        desired.frame_time,
        values,
        tuple(c.id for c in neighbours),
        tuple(FEATURE_NAMES[i] for i in components),
        timings,
    )


def _hmm_path(
    encoding: Encoding,
    desired: Motion,
    neighbours: Sequence[Motion],
    params: GenerationParams,
    timings: dict[str, float],
) -> FloatArray:
    if encoding.dimension == 0:  # nothing to model: the desired path is the answer
        timings["hmm_fit"] = timings["viterbi"] = 0.0
        return desired.values.copy()
    desired_obs = encode(encoding, desired)
    sequences = [encode(encoding, m) for m in neighbours]
    sequences += [desired_obs] * max(0, params.nd)
    clock = time.perf_counter()
    trained = train_hmm(sequences, params.states, n_iter=params.n_iter)
    timings["hmm_fit"] = time.perf_counter() - clock
    clock = time.perf_counter()
    # Align on movement, not stance: the desired path is moved onto the training data's mean
    # and spread per dimension before Viterbi, else a performer's different posture pins
    # every frame to one state (the paper's data all started from one T-pose).
    pooled = np.vstack(sequences)
    spread = desired_obs.std(axis=0)
    aligned = (desired_obs - desired_obs.mean(axis=0)) / np.where(spread > 1e-9, spread, 1.0)
    aligned = aligned * pooled.std(axis=0) + pooled.mean(axis=0)
    states = trained.viterbi(aligned).astype(int)
    if params.regenerate == "frames":
        training = sequences[: len(neighbours)]
        labels = [trained.viterbi(sequence).astype(int) for sequence in training]
        frames = state_aligned_frames(states, trained.means, training, labels)
    timings["viterbi"] = time.perf_counter() - clock
    if params.regenerate == "frames":
        path = smooth(frames, desired.frame_time, params.cutoff_hz)
    else:
        path = smooth(state_path(trained.means, states), desired.frame_time, params.cutoff_hz)
    return decode(encoding, path, desired.values[0])


def time_warp(values: FloatArray, frame_time: float, duration: float) -> tuple[FloatArray, float]:
    """Resample ``values`` linearly to last exactly ``duration`` seconds."""
    frames = max(2, round(duration / frame_time))
    source = np.linspace(0.0, 1.0, len(values))
    target = np.linspace(0.0, 1.0, frames)
    if len(values) == 1:
        return np.repeat(values, frames, axis=0), duration / frames
    warped = np.empty((frames, values.shape[1]))
    for column in range(values.shape[1]):
        warped[:, column] = np.interp(target, source, values[:, column])
    return warped, duration / frames


def generate_motion(
    library: MotionLibrary,
    action: str,
    style: str,
    *,
    duration: float | None = None,
    clip: str | None = None,
    original_style: str | None = None,
    params: GenerationParams | None = None,
    exclude: Sequence[str] = (),
) -> Generated:
    """Generate ``action`` in ``style`` (see the module docstring); ``exclude`` lists clip
    ids that must not be used (leave-one-out evaluation)."""
    params = params or GenerationParams()
    if not library.select(action):
        raise MotionUnavailable(f"no clip of action {action!r}")
    started = time.perf_counter()
    desired_clip = _pick_desired(library, action, clip)
    original = original_style or desired_clip.style
    excluded = set(exclude)
    key = (library.content_hash, action, style, desired_clip.id, original, params, tuple(sorted(excluded)))
    modulated = _CACHE.get(key)
    cached = modulated is not None
    if modulated is None:
        modulated = _modulate(library, action, style, desired_clip, original, params, excluded)
        _CACHE[key] = modulated
    values, frame_time = modulated.values, modulated.frame_time
    if duration is not None:
        values, frame_time = time_warp(values, frame_time, duration)
    timings = dict(modulated.timings) if not cached else {}
    timings["total"] = time.perf_counter() - started
    return Generated(
        Motion(modulated.skeleton, frame_time, values),
        action,
        style,
        desired_clip.id,
        modulated.neighbours,
        modulated.components,
        timings,
        cached,
    )

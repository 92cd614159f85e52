"""Affective motion generation: the paper's Fig. 2 (RMLR + LMA neighbours + HMM/Viterbi).

``generate_motion(library, action, style, duration=...)``:

1. the desired path X_d is the leaf's ``clip`` (a library clip id) or, by default, the
   action's ``normal`` clip (else its first clip); its own style is the original emotion;
   a leaf in that same style plays the desired path itself (:func:`_own_style`);
2. LMA features of the clips (cached), RMLR saliency (cached) -> the affectively
   non-discriminative components for (original, target) (eq. 12);
3. the ε-neighbourhood of X_d among the target-style clips of the same action, widened to
   the nearest ``min_neighbours`` and cut to ``max_neighbours`` (8 and 8: on Bandai dataset 2
   the ε rule alone kept 1-3 clips; with 8 the recognition of generated clips rose from 76 to
   79 % on one fold, fidelity from 75 to 80 %);
4. HMM_NN trained on the neighbours plus ``nd`` copies of X_d, in the phase space of
   :mod:`mse.motion.lma_hmm.pose` (:mod:`mse.motion.lma_hmm.hmm`);
5. Viterbi state sequence of X_d; the sequence of state means (the states' mean joint
   rotations over the neighbours, ramps between the midpoints of state runs), zero-phase
   low-pass filter (Butterworth, 3 Hz); ``GenerationParams(regenerate="frames")`` instead
   plays the neighbours' own frames of each state in X_d's state order and timing;
6. time-warp (linear resampling of the rotation vectors, never of Euler angles) to the
   requested duration: ``round(duration / frame_time)`` frames, the frame time adjusted so
   that the clip lasts exactly ``duration``; a cyclic path (a walk) scheduled for much longer
   than its desired path is first continued with the neighbours' own state sequences
   (:func:`continue_cycle`): more steps, not slower ones;
7. the root from the feet (:func:`mse.motion.base.contacts.ground`): the lowest foot point
   on the floor and pinned, so the stance foot never slides and walks travel by their steps;
   in the flight phases of runs (the neighbours' support, carried through the states like
   the rotations) the body keeps the neighbours' speed and lift.

Waves (neighbours that stand and cycle): the phase space also holds the velocity, runs
where the decoding sat in one state are played, and changes of state the neighbours never
make bridged, by the neighbours' own sequences, the cut-off is at most twice their cycle rate,
and a standing body pins its lowest foot point without the stance hysteresis
(``GenerationParams.velocity`` and ``standing_pin``; docs/motion.md, "Generation", step 11).
Any standing body (:mod:`mse.motion.lma_hmm.standing`) has its arms' spread widened towards
the neighbours' (``arm_spread_cap``) and lands its hops on the floor; ``shared_stance`` (off)
gives its neighbours one leg posture.

Steps 1-5 are cached per (library fingerprint, action, style, desired clip, parameters) in
memory and, when ``cache_dir`` is given, on disk (:mod:`mse.motion.lma_hmm.modulated`), so a leaf
seen before costs the time-warp and the grounding only. Rotations are generated, never
positions: bone lengths are the desired path's.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from mse.diagnostics import Diagnostic, MseError, Span
from mse.motion.base.bvh import Motion
from mse.motion.base.contacts import STANCE_HYSTERESIS, contact_height, ground, support
from mse.motion.base.heading import heading, turned
from mse.motion.base.kinematics import FloatArray
from mse.motion.base.library import Clip, MotionLibrary, MotionUnavailable
from mse.motion.base.lma import FEATURE_NAMES
from mse.motion.lma_hmm.hmm import (
    TOPOLOGIES,
    decode,
    encode,
    encoding_for,
    retimed,
    smooth,
    state_aligned_frames,
    state_means,
    state_path,
    train_hmm,
)
from mse.motion.lma_hmm.modulated import (
    CARRIED,
    DISK_FORMAT,
    LOOP_RATIO,
    Modulated,
    cutoff,
    load,
    path_for,
    save,
    time_warp,
)
from mse.motion.lma_hmm.pose import PhaseSpace, phase_space, pose_features, with_velocity
from mse.motion.lma_hmm.search import (
    EPSILON_FRACTION,
    clip_features,
    feature_table,
    nearest_neighbours,
    saliency_for,
)
from mse.motion.lma_hmm.standing import (
    ARM_SPREAD_CAP,
    arm_variance,
    cycle_rate,
    expected_variance,
    landed_support,
    leg_length,
    shared_stance,
    stands,
    steady_legs,
)
from mse.motion.lma_hmm.stride import STRIDE_CHOICES, restore_stride, travels

__all__ = ["Generated", "GenerationParams", "MotionUnavailable", "generate_motion", "time_warp"]


VELOCITY_CHOICES = ("standing", "always", "never")


@dataclass(frozen=True, slots=True)
class GenerationParams:
    states: int = 12
    nd: int = 0
    epsilon_fraction: float = EPSILON_FRACTION
    cutoff_hz: float = 3.0
    n_iter: int = 10
    #: "means": the paper's sequence of state means; "frames": the neighbours' own frames of
    #: each state in the desired path's state order and timing (keeps within-state motion)
    regenerate: str = "means"
    #: HMM topology: "auto" (fully connected when the neighbours cycle, else left-to-right),
    #: "full" (the paper's), "left-to-right"
    topology: str = "auto"
    #: the ε-neighbourhood is widened to the nearest ``min_neighbours`` and cut to the nearest
    #: ``max_neighbours`` (the HMM's cost grows with them)
    min_neighbours: int = 8
    max_neighbours: int = 8
    #: "neighbours": each state run of the desired path lasts as the neighbours' runs of that
    #: state (:func:`~mse.motion.lma_hmm.hmm.retimed`: the target style's tempo); "desired":
    #: the desired path's own Viterbi timing (the paper's)
    timing: str = "neighbours"
    #: legs of a clip whose neighbours stand still low-passed at this cut-off (0: off, the
    #: default: at 0.5 Hz the feminine wave's free foot stopped sliding, 1.07 -> 0.23 cm/s,
    #: but active waves lost their legs' rhythm and were all rated youthful, fold 1)
    standing_legs_hz: float = 0.0
    #: when the HMM is fully connected (the neighbours cycle), the phase space also holds the
    #: movement's velocity (:func:`~mse.motion.lma_hmm.pose.with_velocity`) and the HMM is
    #: fitted again, and a run where the desired path's decoding sat in one state is played
    #: by the neighbours' own sequence (``retimed(refill_stuck=True)``): "standing" (default)
    #: when the neighbours stand (waves), "always", "never" (the paper's positions only).
    #: With positions only, waves decoded against slower styles turned back in the middle of
    #: the swing: Samadani fold 1 wave jerk over 2x real in 8 of 42 conversions, 0 with it
    velocity: str = "standing"
    #: weight of the velocity against the positions in the phase space
    velocity_weight: float = 0.3
    #: a standing body (the neighbours' carried root speed under 0.1 leg lengths per second)
    #: pins whichever foot point is lowest, without the walks' stance hysteresis
    standing_pin: bool = True
    #: travelling neighbours (``stride.travels``): the state means' swing widened, joint by joint,
    #: to the neighbours' own (:mod:`mse.motion.lma_hmm.stride`): "legs", "all", "off"
    stride: str = "legs"
    #: travelling neighbours that cycle: a change of state they never make in the desired
    #: path's decoding goes through the states by which they do (``hmm.retimed(bridge=True)``),
    #: and a path shorter than the clip is continued, not stretched (``modulated.path_for``)
    travel_cycles: bool = True
    #: a standing body's arm rotations widened towards the neighbours' spread, by at most this
    #: factor (:func:`~mse.motion.lma_hmm.standing.arm_variance`; 1: off, the method before)
    arm_spread_cap: float = ARM_SPREAD_CAP
    #: a standing body's neighbours share one leg posture before the state means are taken
    #: (:func:`~mse.motion.lma_hmm.standing.shared_stance`)
    shared_stance: bool = False

    def __post_init__(self) -> None:
        if self.regenerate not in ("means", "frames"):
            raise ValueError(f"regenerate must be 'means' or 'frames', not {self.regenerate!r}")
        if self.timing not in ("neighbours", "desired"):
            raise ValueError(f"timing must be 'neighbours' or 'desired', not {self.timing!r}")
        if self.velocity not in VELOCITY_CHOICES:
            raise ValueError(f"velocity must be one of {', '.join(VELOCITY_CHOICES)}, not {self.velocity!r}")
        if self.stride not in STRIDE_CHOICES:
            raise ValueError(f"stride must be one of {', '.join(STRIDE_CHOICES)}, not {self.stride!r}")
        if not self.arm_spread_cap >= 1.0:
            raise ValueError(f"arm_spread_cap must be at least 1 (1: off), not {self.arm_spread_cap!r}")
        if self.topology not in TOPOLOGIES:
            raise ValueError(f"topology must be one of {', '.join(TOPOLOGIES)}, not {self.topology!r}")


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
    cyclic: bool = False


_CACHE: dict[str, Modulated] = {}
_POSES: dict[tuple[str, str], FloatArray] = {}


def clear_cache() -> None:
    _CACHE.clear()
    _POSES.clear()


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


def _facing(library: MotionLibrary, clip: Clip, facing: float) -> Motion:
    motion = library.motion(clip)
    return turned(motion, facing - heading(motion))


def _pose(library: MotionLibrary, clip: Clip) -> FloatArray:
    key = (library.content_hash, clip.id)
    features = _POSES.get(key)
    if features is None:
        features = pose_features(library.motion(clip))
        _POSES[key] = features
    return features


def _neighbours(
    library: MotionLibrary,
    action: str,
    style: str,
    desired_clip: Clip,
    original: str | None,
    params: GenerationParams,
    exclude: set[str],
    timings: dict[str, float],
) -> tuple[list[Clip], tuple[str, ...]]:
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
        return [desired_clip], ()
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
    chosen = nearest_neighbours(
        desired_features,
        candidate_features,
        components,
        saliency,
        params.epsilon_fraction,
        minimum=params.min_neighbours,
        maximum=params.max_neighbours,
    )
    timings["nn_search"] = time.perf_counter() - clock
    return [candidates[i] for i in chosen], tuple(FEATURE_NAMES[i] for i in components)


def _modulate(
    library: MotionLibrary,
    action: str,
    style: str,
    desired_clip: Clip,
    original: str | None,
    params: GenerationParams,
    exclude: set[str],
) -> Modulated:
    timings: dict[str, float] = {"lma": 0.0, "rmlr": 0.0, "nn_search": 0.0}
    desired = library.motion(desired_clip)
    if style == desired_clip.style and original == style:
        return _own_style(desired_clip.id, desired, _pose(library, desired_clip), params, timings)
    neighbours, components = _neighbours(library, action, style, desired_clip, original, params, exclude, timings)
    # the neighbours turned to face the desired path's way (their room directions differ)
    facing = heading(desired)
    motions = [_facing(library, c, facing) for c in neighbours]

    clock = time.perf_counter()
    encoding = encoding_for(desired)
    poses = [_pose(library, c) for c in neighbours]
    space: PhaseSpace = phase_space(poses)
    phases = [space.observe(p) for p in poses]
    desired_phase = space.observe(_pose(library, desired_clip))
    # rotations (faced as the desired path) and, in the last 4 columns, how the neighbours are
    # carried: root velocity, foot lift, support (flight phases of runs, base.contacts.support)
    carried = [support(m) for m in motions]
    rotations = [np.hstack([encode(encoding, m), c]) for m, c in zip(motions, carried, strict=True)]
    copies = max(0, params.nd)
    trained = train_hmm(
        phases + [desired_phase] * copies,
        params.states,
        topology=params.topology,
        n_iter=params.n_iter,
        decide_on=len(phases),
    )
    # a cycling movement of a standing body (waves): the phase space also holds the velocity,
    # and the HMM is fitted again, fully connected (see GenerationParams.velocity)
    dynamic = params.velocity == "always" or (params.velocity == "standing" and stands(carried, encoding.skeleton))
    if dynamic and trained.cyclic:
        phases = [with_velocity(p, params.velocity_weight) for p in phases]
        desired_phase = with_velocity(desired_phase, params.velocity_weight)
        trained = train_hmm(
            phases + [desired_phase] * copies,
            params.states,
            topology="full" if params.topology == "auto" else params.topology,
            n_iter=params.n_iter,
            decide_on=len(phases),
        )
    if params.shared_stance and stands(carried, encoding.skeleton):
        rotations = shared_stance(rotations, encoding)
    timings["hmm_fit"] = time.perf_counter() - clock

    clock = time.perf_counter()
    states = trained.viterbi(desired_phase)
    training_rotations = rotations + [np.hstack([encode(encoding, desired), support(desired)])] * copies
    means = state_means(trained, phases + [desired_phase] * copies, training_rotations)
    retime = params.timing == "neighbours"
    needs_labels = trained.cyclic or params.regenerate == "frames" or retime
    labels = [trained.viterbi(p) for p in phases] if needs_labels else []
    travelling = travels(carried, leg_length(encoding.skeleton))
    if params.stride != "off" and travelling:
        # the state means under-shoot the swing of the legs: the stride (stride.py)
        own = labels or [trained.viterbi(p) for p in phases]
        means = restore_stride(means, rotations, own, desired.frame_time, params.cutoff_hz, encoding, params.stride)
    if retime:
        # travelling neighbours (walks, runs): a change of state they never make is bridged
        # too (stride.py: the desired path's start turned the legs back, a jolt of the root)
        bridge = trained.cyclic and (dynamic or (params.travel_cycles and travelling))
        states = retimed(states, labels, refill_stuck=dynamic and trained.cyclic, bridge=bridge)
    if params.regenerate == "frames":
        frames = state_aligned_frames(states, means, rotations, labels)
    timings["viterbi"] = time.perf_counter() - clock

    clock = time.perf_counter()
    raw = frames if params.regenerate == "frames" else state_path(means, states)
    runs = 1 + int(np.count_nonzero(np.diff(states)))
    hz = cutoff(params.cutoff_hz, len(raw), runs, desired.frame_time)
    if dynamic and trained.cyclic:
        # a wave's short runs raised the cut-off to 4-5 Hz, and the ramps between state means
        # came through as jerk (a youthful wave, Samadani fold 1: 44,300 cm/s^3, limit 33,400;
        # at 3 Hz 24,100, amplitude 31.2 -> 30.9 cm): up to twice the neighbours' cycle rate
        hz = min(hz, max(params.cutoff_hz, 2.0 * cycle_rate(labels, desired.frame_time)))
    path = smooth(raw, desired.frame_time, hz)
    if params.arm_spread_cap > 1.0 and stands(carried, encoding.skeleton):
        target = expected_variance(trained, phases + [desired_phase] * copies, training_rotations, states)
        path, means = arm_variance(path, means, encoding, target, params.arm_spread_cap)
    timings["filter"] = time.perf_counter() - clock
    return Modulated(
        encoding,
        desired.frame_time,
        path,
        contact_height(motions),
        tuple(c.id for c in neighbours),
        components,
        trained.cyclic,
        timings,
        states.astype(np.int_),
        means,
        tuple(labels),
        params.cutoff_hz,
    )


def _travels(modulated: Modulated) -> bool:
    """Whether the modulated path travels: its carried root velocity (the neighbours',
    through the states; :func:`~mse.motion.lma_hmm.stride.travels`)."""
    path, encoding = modulated.path, modulated.encoding
    if path.shape[1] != encoding.dimension + CARRIED:
        return False
    return travels([path[:, encoding.dimension :]], leg_length(encoding.skeleton))


def _own_style(
    clip_id: str, desired: Motion, pose: FloatArray, params: GenerationParams, timings: dict[str, float]
) -> Modulated:
    """The desired path in its own style: played as it is. The paper converts between
    styles; regenerating a clip in its own style through 12 state means only loses detail
    (Bandai dataset 1's 63 s dance, one clip, decoded by a fully connected 12-state model:
    hand range 80 -> 50 cm, head dip 86 -> 63 cm). The HMM of the clip alone still gives
    the states with which a cyclic clip scheduled for longer is continued."""
    clock = time.perf_counter()
    encoding = encoding_for(desired)
    space = phase_space([pose])
    phase = space.observe(pose)
    trained = train_hmm([phase], params.states, topology=params.topology, n_iter=params.n_iter)
    states = trained.viterbi(phase)
    path = np.hstack([encode(encoding, desired), support(desired)])
    means = state_means(trained, [phase], [path])
    timings["hmm_fit"] = time.perf_counter() - clock
    return Modulated(
        encoding,
        desired.frame_time,
        path,
        contact_height([desired]),
        (clip_id,),
        (),
        trained.cyclic,
        timings,
        states.astype(np.int_),
        means,
        (states.astype(np.int_),),
        params.cutoff_hz,
    )


def _key(library: MotionLibrary, action: str, style: str, desired: str, original: str, params: GenerationParams,
         exclude: set[str]) -> str:
    text = json.dumps(
        [DISK_FORMAT, library.content_hash, action, style, desired, original, asdict(params), sorted(exclude)]
    )
    return hashlib.sha256(text.encode()).hexdigest()[:24]


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
    cache_dir: str | os.PathLike[str] | None = None,
) -> Generated:
    """Generate ``action`` in ``style`` (see the module docstring); ``exclude`` lists clip
    ids that must not be used (leave-one-out evaluation); ``cache_dir`` keeps the modulated
    paths on disk between runs."""
    params = params or GenerationParams()
    if not library.select(action):
        raise MotionUnavailable(f"no clip of action {action!r}")
    started = time.perf_counter()
    desired_clip = _pick_desired(library, action, clip)
    original = original_style or desired_clip.style
    excluded = set(exclude)
    key = _key(library, action, style, desired_clip.id, original, params, excluded)
    modulated = _CACHE.get(key)
    cached = modulated is not None
    disk = Path(cache_dir) / f"{key}.npz" if cache_dir is not None else None
    if modulated is None and disk is not None and disk.is_file():
        modulated = load(disk)
        cached = modulated is not None
    if modulated is None:
        modulated = _modulate(library, action, style, desired_clip, original, params, excluded)
        if disk is not None:
            with contextlib.suppress(OSError):  # the cache is an optimisation only
                save(disk, modulated)
    _CACHE[key] = modulated
    path, frame_time = modulated.path, modulated.frame_time
    own_style = modulated.neighbours == (desired_clip.id,) and not modulated.components
    # a travelling cycle shorter than the clip takes more steps rather than slower ones (not
    # an own-style copy: continued through its state means, a normal punch lost its reach)
    continued = params.travel_cycles and modulated.cyclic and not own_style and _travels(modulated)
    loop = 1.0 if continued else LOOP_RATIO
    if duration is not None:
        path = path_for(modulated, round(duration / frame_time), loop)
        path, frame_time = time_warp(path, frame_time, duration)
    encoding = modulated.encoding
    if params.standing_legs_hz > 0 and not own_style and path.shape[1] == encoding.dimension + CARRIED:
        path = steady_legs(path, encoding, frame_time, params.standing_legs_hz)
    motion = Motion(encoding.skeleton, frame_time, decode(encoding, path))
    carried = path[:, encoding.dimension :].copy()
    if carried.shape[1] == CARRIED and duration is not None:
        # the path was played slower or faster than its neighbours: so is the carried speed
        played = len(path_for(modulated, round(duration / modulated.frame_time), loop)) * modulated.frame_time
        carried[:, :2] *= played / max(duration, 1e-9)
    # a standing body pins whichever foot point is lowest, without the walks' hysteresis (as
    # the HSMM method does): with both feet on the floor, the hysteresis kept the left toes
    # pinned while the right ones, 0.04 cm lower, slid with the legs' state means (dataset 2
    # feminine waves, fold 1: foot slip 1.0-1.5 cm/s, limit 0.9)
    standing = carried.shape[1] == CARRIED and params.standing_pin and stands([carried], encoding.skeleton)
    if standing:
        carried = landed_support(carried)
    motion = ground(
        motion,
        modulated.height,
        carried=carried if carried.shape[1] == CARRIED else None,
        hysteresis=0.0 if standing else STANCE_HYSTERESIS,
    )
    timings = dict(modulated.timings) if not cached else {}
    timings["total"] = time.perf_counter() - started
    return Generated(
        motion,
        action,
        style,
        desired_clip.id,
        modulated.neighbours,
        modulated.components,
        timings,
        cached,
        modulated.cyclic,
    )

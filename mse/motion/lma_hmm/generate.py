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
(``GenerationParams.velocity``; docs/motion.md, "Generation", step 11);
standing neighbours that cycle by their velocity only (slow, small feminine waves) are
judged so and treated as waves (``standing.CYCLE_VELOCITY_WEIGHT``).
Any standing body (:mod:`mse.motion.lma_hmm.standing`) has its arms' spread widened towards
what its states hold, as far as the hands' jerk stays within the neighbours'
(``standing.spread_cap``), and lands its hops on the floor, and its
neighbours share one leg posture (``standing.shared_stance``).

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
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from mse.motion.base import cache
from mse.motion.base.bodyparts import body_map
from mse.motion.base.bvh import Motion
from mse.motion.base.contacts import STANCE_HYSTERESIS, contact_height, ground, support
from mse.motion.base.cycles import ActionShape, action_shape, leg_length
from mse.motion.base.heading import heading, heading_track, in_heading_frame, turn_rate, turned_along, turning_rate
from mse.motion.base.kinematics import FloatArray
from mse.motion.base.library import Clip, MotionLibrary, MotionUnavailable
from mse.motion.base.loop import EDGE_SHARE, held, looped, rested, rested_facing, shorter_than_a_cycle
from mse.motion.lma_hmm.hmm import (
    Encoding,
    decode,
    encode,
    encoding_for,
    smooth,
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
from mse.motion.lma_hmm.neighbours import clip_motion, facing_motion, find_neighbours, pick_desired, pose_of
from mse.motion.lma_hmm.params import GenerationParams
from mse.motion.lma_hmm.pose import PhaseSpace, phase_space, with_velocity
from mse.motion.lma_hmm.standing import (
    ARM_SPREAD_CAP,
    CYCLE_VELOCITY_WEIGHT,
    arm_variance,
    cycle_rate,
    cycles_by_velocity,
    expected_variance,
    hand_jerk,
    landed_support,
    shared_stance,
    spread_cap,
    stands,
)
from mse.motion.lma_hmm.stride import restore_stride, travels
from mse.motion.lma_hmm.timing import retimed, state_aligned_frames

__all__ = ["Generated", "GenerationParams", "MotionUnavailable", "generate_motion", "time_warp"]


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
    # turning locomotion (measured from the clips): every clip straightened, frame by frame,
    # to its path's heading; the generated path is turned at the clips' rate (generate_motion)
    turning = action_turn_of(library, action) != 0.0
    desired = clip_motion(library, desired_clip, turning)
    start_yaw = float(heading_track(library.motion(desired_clip))[0]) if turning else 0.0
    if style == desired_clip.style and original == style:
        shape = action_shape_of(library, action)
        as_is = _own_style(desired_clip.id, desired, pose_of(library, desired_clip, turning), params, timings, shape)
        rate = turn_rate(library.motion(desired_clip)) if turning else 0.0
        return replace(as_is, turn_rate=rate, start_yaw=start_yaw)
    neighbours, components = find_neighbours(library, action, style, desired_clip, original, params, exclude, timings)
    # the neighbours turned to face the desired path's way (their room directions differ)
    facing = heading(desired)
    motions = [facing_motion(library, c, facing, turning) for c in neighbours]

    clock = time.perf_counter()
    encoding = encoding_for(desired)
    poses = [pose_of(library, c, turning) for c in neighbours]
    space: PhaseSpace = phase_space(poses)
    phases = [space.observe(p) for p in poses]
    desired_phase = space.observe(pose_of(library, desired_clip, turning))
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
    elif dynamic and params.topology == "auto":
        # a slow, small wave (feminine) cycles by its velocity only (standing.cycles_by_velocity)
        found = cycles_by_velocity(
            phases, desired_phase, copies, params.states, params.n_iter, CYCLE_VELOCITY_WEIGHT
        )
        if found is not None:
            trained, phases, desired_phase = found
    if stands(carried, encoding.skeleton):
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
        bridge = trained.cyclic and (dynamic or travelling)
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
    if stands(carried, encoding.skeleton):
        target = expected_variance(trained, phases + [desired_phase] * copies, training_rotations, states)
        jerk = hand_jerk(Motion(encoding.skeleton, desired.frame_time, decode(encoding, path)))
        room = spread_cap(jerk, [hand_jerk(m) for m in motions], ARM_SPREAD_CAP)
        path, means = arm_variance(path, means, encoding, target, room)
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
        action_shape_of(library, action),
        # the target style's own turn: the neighbours' median rate
        float(np.median([turn_rate(library.motion(c)) for c in neighbours])) if turning else 0.0,
        start_yaw,
    )


#: clips per action measured by :func:`action_shape_of` (spread over the action's clips)
SHAPE_CLIPS = 12


def _shape_clips(library: MotionLibrary, action: str) -> list[Clip]:
    clips = library.select(action)
    return clips[:: max(1, len(clips) // SHAPE_CLIPS)][:SHAPE_CLIPS]


def action_shape_of(library: MotionLibrary, action: str) -> ActionShape:
    """What ``action``'s clips do (:func:`mse.motion.base.cycles.action_shape`, on at most
    :data:`SHAPE_CLIPS` of them, spread evenly; cached)."""
    chosen = _shape_clips(library, action)
    return cache.remembered(
        ("shape", library.content_hash, tuple(c.id for c in chosen)),
        lambda: action_shape([library.motion(c) for c in chosen]),
    )


def action_turn_of(library: MotionLibrary, action: str) -> float:
    """Radians per second ``action``'s locomotion turns
    (:func:`mse.motion.base.heading.turning_rate` of the clips of :func:`action_shape_of`;
    0: it goes straight, or does not travel; cached)."""
    if not action_shape_of(library, action).travels:
        return 0.0
    chosen = _shape_clips(library, action)
    return cache.remembered(
        ("turn", library.content_hash, tuple(c.id for c in chosen)),
        lambda: turning_rate([library.motion(c) for c in chosen]),
    )


def _travels(modulated: Modulated) -> bool:
    """Whether the modulated path travels: its carried root velocity (the neighbours',
    through the states; :func:`~mse.motion.lma_hmm.stride.travels`)."""
    path, encoding = modulated.path, modulated.encoding
    if path.shape[1] != encoding.dimension + CARRIED:
        return False
    return travels([path[:, encoding.dimension :]], leg_length(encoding.skeleton))


def _own_style(
    clip_id: str,
    desired: Motion,
    pose: FloatArray,
    params: GenerationParams,
    timings: dict[str, float],
    shape: ActionShape,
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
        shape,
    )


def _key(library: MotionLibrary, action: str, style: str, desired: str, original: str, params: GenerationParams,
         exclude: set[str]) -> str:
    text = json.dumps(
        [DISK_FORMAT, library.content_hash, action, style, desired, original, asdict(params), sorted(exclude)]
    )
    return hashlib.sha256(text.encode()).hexdigest()[:24]


def _rested(path: FloatArray, frames: int, frame_time: float, encoding: Encoding) -> FloatArray:
    """:func:`mse.motion.base.loop.rested_facing`: the root joint (the one the legs hang from)
    rests facing where the body faces."""
    root = encoding.skeleton.parents[body_map(encoding.skeleton).left_hip]
    if root not in encoding.rotated:
        return rested(path, frames, frame_time)
    k = encoding.rotated.index(root)
    up = encoding.references[k].T @ np.array([0.0, 1.0, 0.0])
    return rested_facing(path, frames, frame_time, slice(3 * k, 3 * k + 3), up / np.linalg.norm(up))


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
    desired_clip = pick_desired(library, action, clip)
    original = original_style or desired_clip.style
    excluded = set(exclude)
    key = _key(library, action, style, desired_clip.id, original, params, excluded)
    disk = cache.disk_entry(cache_dir, f"{key}.npz")
    built: list[bool] = []

    def build() -> Modulated:
        found = load(disk) if disk is not None and disk.is_file() else None
        if found is None:
            found = _modulate(library, action, style, desired_clip, original, params, excluded)
            built.append(True)
            if disk is not None:
                with contextlib.suppress(OSError):  # the cache is an optimisation only
                    save(disk, found)
        return found

    modulated = cache.remembered(("modulated", key), build)
    cached = not built
    path, frame_time = modulated.path, modulated.frame_time
    own_style = modulated.neighbours == (desired_clip.id,) and not modulated.components
    # a travelling cycle shorter than the clip takes more steps rather than slower ones (not
    # an own-style copy: continued through its state means, a normal punch lost its reach)
    continued = modulated.cyclic and not own_style and _travels(modulated)
    loop = 1.0 if continued else LOOP_RATIO
    played = len(path) * frame_time
    if duration is not None:
        wanted = round(duration / frame_time)
        shape = modulated.shape
        if shorter_than_a_cycle(wanted, len(path), frame_time, shape.period_s):
            # shorter than one cycle (an action that does not cycle: than its path): started
            # at its tempo, ended on the rest pose (base.loop)
            path = _rested(path, wanted, frame_time, modulated.encoding)
        elif shape.cyclic or wanted < LOOP_RATIO * len(path):
            # (an action that does not cycle, measured on its clips, is not continued through
            # its state means even when its path's HMM cycles: a normal punch lost its reach)
            path = path_for(modulated, wanted, loop)
        if wanted >= LOOP_RATIO * len(path) and shape.cyclic:
            # the action cycles (measured on its clips) but the path was not continued (an
            # own-style copy, or neighbours the HMM did not judge cyclic): its cycles repeat at
            # their tempo (base.loop) rather than slow down (Bandai dataset 1 normal run at 2x
            # its length: 1.25 steps/s and 121 cm/s, the take 2.73 and 261)
            path = looped(
                path, wanted, frame_time, 0.0 if shape.travels else EDGE_SHARE, shape.period_s, not shape.travels
            )
        elif wanted >= LOOP_RATIO * len(path):
            path = held(path, wanted)  # at its own tempo, then at rest (base.loop)
        played = len(path) * frame_time
        path, frame_time = time_warp(path, frame_time, duration)
    encoding = modulated.encoding
    motion = Motion(encoding.skeleton, frame_time, decode(encoding, path))
    carried = path[:, encoding.dimension :].copy()
    if carried.shape[1] == CARRIED and duration is not None:
        # the path was played slower or faster than its neighbours: so is the carried speed
        carried[:, :2] *= played / max(duration, 1e-9)
    if modulated.turn_rate != 0.0:
        # turning locomotion was generated straight (its steps): its heading turns at the
        # clips' rate, from the desired path's first heading; so do the carried velocities
        yaws = modulated.start_yaw + modulated.turn_rate * frame_time * np.arange(len(path), dtype=np.float64)
        motion = turned_along(motion, yaws)
        if carried.shape[1] == CARRIED:
            carried[:, :2] = in_heading_frame(carried[:, :2], -yaws)
    # a standing body pins whichever foot point is lowest, without the walks' hysteresis (as
    # the HSMM method does): with both feet on the floor, the hysteresis kept the left toes
    # pinned while the right ones, 0.04 cm lower, slid with the legs' state means (dataset 2
    # feminine waves, fold 1: foot slip 1.0-1.5 cm/s, limit 0.9)
    standing = carried.shape[1] == CARRIED and stands([carried], encoding.skeleton)
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

"""HSMM synthesis (paper §5.1.4, §5.2.3): units → state durations → MLPG (+GV) → BVH motion.

* Units: cyclic actions concatenate ``first``, alternating ``inner`` steps and ``last``;
  one-shot actions use their single unit.
* Durations: per-state duration Gaussians scaled to the requested length the HTS way,
  ``d = m + ρ σ²`` with ``ρ = (T - Σm) / Σσ²`` (states clipped at one frame are held and ρ
  recomputed), then rounded keeping the total exact.  With a seed, the means are first drawn
  from the duration Gaussians (states above the variance floor) so that repeated leaves
  differ slightly.
* Parameters: MLPG with global variance (option off), exponential maps → local rotations.
* Root: :func:`mse.motion.base.contacts.root_track`: the lowest contact point (foot/toes)
  sits at the training contact height and is pinned while it is the lowest (the stance foot
  does not slide); one-shot actions first low-pass their legs' rotations (:func:`still_legs`).
"""

from __future__ import annotations

import numpy as np

from mse.extras import require
from mse.limits import MAX_MOTION_SECONDS, MAX_STEPS
from mse.motion.base.bvh import Motion
from mse.motion.base.contacts import root_track
from mse.motion.base.filters import zero_phase_lowpass
from mse.motion.base.kinematics import forward_kinematics, matrix_to_euler
from mse.motion.base.loop import held, looped, rest_ease_frames, rested, shorter_than_a_cycle
from mse.motion.hsmm.carried import carried_track, smooth_carried
from mse.motion.hsmm.features import FloatArray, yaw_matrix
from mse.motion.hsmm.mlpg import generate_with_gv, mlpg
from mse.motion.hsmm.model import DURATION_VARIANCE_FLOOR, HsmmModel, UnitModel
from mse.motion.hsmm.prep import Template, facing_as, local_rotations_from_features
from mse.motion.hsmm.segment import ONE_SHOT_UNIT


def _other(leg: str) -> str:
    return "b" if leg == "a" else "a"


def plan_units(model: HsmmModel, steps: int | None = None, frames: int | None = None) -> list[str]:
    """Unit names for ``steps`` steps, or as many as fit ``frames`` frames on average."""
    if not model.cyclic or ONE_SHOT_UNIT in model.units:
        return [ONE_SHOT_UNIT if ONE_SHOT_UNIT in model.units else next(iter(model.units))]
    leg = model.first_leg
    if steps is None:
        total = frames if frames is not None else 0
        first = float(model.unit(f"first-{leg}").duration_means.sum())
        last = float(model.unit("last-a").duration_means.sum())
        inner = float(model.unit("inner-a").duration_means.sum())
        steps = 2 + max(0, round((total - first - last) / max(inner, 1.0)))
        steps = _ending_as_clips(model, steps, total, first, inner)
    steps = max(2, steps)
    names = [f"first-{leg}"]
    # Hand cycles' unit after the first has a context of its own (see segment.ONE_SHOT_UNIT).
    second = any(name.startswith("second-") for name in model.units)
    for index in range(steps - 2):
        leg = _other(leg)
        names.append(f"{'second' if second and index == 0 else 'inner'}-{leg}")
    names.append(f"last-{_other(leg)}")
    return names


def _last_leg(first_leg: str, steps: int) -> str:
    """The leg of the last unit of a plan of ``steps`` steps starting on ``first_leg``."""
    return _other(first_leg) if steps % 2 == 0 else first_leg


def _ending_as_clips(model: HsmmModel, steps: int, total: int, first: float, inner: float) -> int:
    """``steps``, or one step more or fewer (whichever lasts closer to ``total`` frames) when
    the plan would end on a unit none of the model's clips end on (``info["last_units"]``).

    The plan's last unit follows from the first leg and the count; a unit the clips never
    end on is the average model's, adapted only through the transforms its style shares:
    Bandai dataset 1 walk musical (its take ends on ``last-b``) at twice its length ended on
    ``last-a``, and GV's variance scaling, fitting the take's variance over a trajectory of
    that foreign ending, widened the arms up to 18x (jerk 30,566 cm/s^3, limit 23,415).

    Locomotion only: a hand cycle's last unit is its fall to rest, and ending it on the
    takes' side changed the swings' tempo (one-hand waves made from Bandai dataset 2, youthful
    at 2x: 1.34 -> 1.48 swings/s, its takes 1.15-1.35; exhausted at 1x: 0.78 -> 0.63, its
    takes 0.66-1.03)."""
    ends = model.info.get("last_units")
    if not model.travels or not isinstance(ends, list) or not ends or steps < 2:
        return steps
    if f"last-{_last_leg(model.first_leg, steps)}" in ends:
        return steps
    options = [s for s in (steps - 1, steps + 1) if s >= 2 and f"last-{_last_leg(model.first_leg, s)}" in ends]
    if not options:
        return steps

    def length(count: int) -> float:
        last = float(model.unit(f"last-{_last_leg(model.first_leg, count)}").duration_means.sum())
        return first + last + (count - 2) * inner

    return min(options, key=lambda count: (abs(length(count) - total), count))


def state_durations(
    units: list[UnitModel], frames: int, rng: np.random.Generator | None = None
) -> np.ndarray:
    """Integer frames per state (all units' states in order) summing exactly to ``frames``."""
    means = np.concatenate([u.duration_means for u in units]).astype(np.float64)
    variances = np.concatenate([u.duration_variances for u in units]).astype(np.float64)
    if frames < means.size:
        raise ValueError(f"{frames} frames cannot hold {means.size} states")
    if rng is not None:
        # Only variation the clips show is drawn: a state whose duration variance is at the
        # floor was seen once (or always as long) and keeps its mean. Drawn from the floor,
        # the one-take Bandai dataset 1 kick (90 states of 4 frames) recovered from its second
        # kick with the head 28.5 cm in front of the feet where the take has 22.7 (at 3x,
        # head forward 33.4 cm against 23.6-31.9); now 24.6 (29.0).
        spread = np.sqrt(variances) * (variances > DURATION_VARIANCE_FLOOR)
        means = np.maximum(means + rng.normal(size=means.size) * spread * 0.5, 1.0)
    free = np.ones(means.size, dtype=bool)
    durations = means.copy()
    for _ in range(means.size):
        if not free.any():
            break
        held = float(durations[~free].sum())
        rho = (frames - held - means[free].sum()) / variances[free].sum()
        durations[free] = means[free] + rho * variances[free]
        clipped = free & (durations < 1.0)
        if not clipped.any():
            break
        durations[clipped] = 1.0
        free &= ~clipped
    whole = np.floor(durations).astype(np.int64)
    whole = np.maximum(whole, 1)
    remainder = frames - int(whole.sum())
    order = np.argsort(-(durations - np.floor(durations)))
    index = 0
    while remainder != 0:
        state = order[index % order.size]
        if remainder > 0:
            whole[state] += 1
            remainder -= 1
        elif whole[state] > 1:
            whole[state] -= 1
            remainder += 1
        index += 1
    return whole


#: locomotion generates the root joint's rotation without GV: GV widened the root's swing
#: around the clip's mean heading, so the first frame faced 7-21 deg off the real take's
#: and side speed (measured from the first frame's hips) missed on diagonal walks (Bandai
#: dataset 1 walk-right sad -8.4 -> -23.0 cm/s, musical -15.8 -> -17.0; real -22.9, -28.6)
ROOT_WITHOUT_GV = True


def _root_columns(template: Template) -> list[int]:
    """Static-feature columns of the root joint's rotation."""
    k = template.rotated.index(template.root_joint)
    return [3 * k, 3 * k + 1, 3 * k + 2]


def _stream_columns(columns: list[int], dims: int) -> list[int]:
    """Observation columns (static, Δ, Δ²) of the given static columns."""
    return [stream * dims + c for stream in range(3) for c in columns]


def generate(
    model: HsmmModel, unit_names: list[str], frames: int, gv: bool = True, seed: int | None = None
) -> tuple[FloatArray, FloatArray | None]:
    """(frames, D) static features for the unit sequence, and (frames, 4) how the body is
    carried (:mod:`mse.motion.hsmm.carried`; None when the model has no such profiles)."""
    units = [model.unit(name) for name in unit_names]
    rng = np.random.default_rng(seed) if seed is not None else None
    durations = state_durations(units, frames, rng)
    means = np.concatenate([u.means for u in units])
    variances = np.concatenate([u.variances for u in units])
    mean_seq = np.repeat(means, durations, axis=0)
    var_seq = np.repeat(variances, durations, axis=0)
    carried = carried_track(units, [model.carried.get(model.resolve(n)) for n in unit_names], durations)
    if not gv:
        return mlpg(mean_seq, var_seq), carried
    statics = generate_with_gv(mean_seq, var_seq, model.gv_mean, model.gv_var)
    if ROOT_WITHOUT_GV and model.travels:
        # Every static dimension is independent in MLPG and GV (diagonal covariances), so
        # the root joint's columns can be generated without GV on their own.
        columns = _root_columns(model.template)
        streams = _stream_columns(columns, statics.shape[1])
        statics[:, columns] = mlpg(mean_seq[:, streams], var_seq[:, streams])
    return statics, carried


def generate_statics(
    model: HsmmModel, unit_names: list[str], frames: int, gv: bool = True, seed: int | None = None
) -> FloatArray:
    """(frames, D) static features for the unit sequence."""
    return generate(model, unit_names, frames, gv, seed)[0]


#: cut-off of the zero-phase low-pass of every generated trajectory (Hz)
OUTPUT_CUTOFF_HZ = 6.0

#: one-shot actions pin whichever foot point is lowest (changes blended as for walks): with
#: both feet on the floor, the walks' hysteresis (keep the stance foot until the other is
#: lower by 1 % of the leg length) let the foot that is actually lowest slide while the other
#: was pinned (Bandai dataset 1, HSMM: byebye, guide and bow foot slip 0.9-7.6 cm/s in 8 of
#: 60 cases where the limit is 0.9; without the hysteresis 0.00 cm/s in all 60; with no blend
#: either, two guides' jerk went over 2x real)
STANDING_PIN = True

#: one-shot actions: cut-off of the low-pass filter of the legs' and the root joint's rotations
STILL_LEGS_CUTOFF_HZ = 1.5


def _leg_columns(template: Template) -> list[int]:
    """Static-feature columns of the root joint and every joint of the two legs."""
    parents = template.skeleton.parents
    joints = {template.root_joint}
    stack = list(template.legs)
    while stack:
        joint = stack.pop()
        joints.add(joint)
        stack.extend(child for child, parent in enumerate(parents) if parent == joint)
    return [3 * k + axis for k, joint in enumerate(template.rotated) if joint in joints for axis in range(3)]


#: standing actions whose training clips lift one foot over the other by more than this share
#: of the leg length (:attr:`Template.feet_lift`, the clips' median of the 95th percentile)
#: move their legs as the real ones do: :func:`still_legs` is for actions that stand on both
#: feet (Bandai dataset 1 bow, bye, byebye, call, guide, respond and dataset 2 raise and
#: wave: 0.000-0.019; slash 0.050, punch 0.059, dance-short 0.57, kick 1.00). Stilled, the
#: punch's knee bend was lost (head dip 6.5 cm, its take 10.2) and the kick's leg swung
#: the body forward (head forward 79.6 cm, the take 68.3).
ACTING_LEGS_LIFT = 0.03


def still_legs(statics: FloatArray, template: Template) -> FloatArray:
    """One-shot actions (bow, raise or wave the hands) stand, but generated legs and pelvis
    wobble: pinning the lowest foot point then carried the body along every small knee and
    ankle movement (an adapted angry bow: hip jerk 20,000 cm/s^3 against 1,200 in the real
    bow), and low-passing the root's track instead let the stance foot slide (1.1-1.6 cm/s,
    over the 2x-real limit of 0.9). So the legs' and the root joint's rotations are low-passed
    (:data:`STILL_LEGS_CUTOFF_HZ`: slow weight shifts and the bow's hip flexion stay) and the
    feet are pinned as for walks (Bandai dataset 2 raise both hands, active: foot slip 1.34 ->
    0.00 cm/s; dataset 1 angry bow 1.34 -> 0.00 cm/s, head jerk 3,484 -> 3,183)."""
    columns = _leg_columns(template)
    smoothed = statics.copy()
    smoothed[:, columns] = zero_phase_lowpass(statics[:, columns], template.frame_time, STILL_LEGS_CUTOFF_HZ)
    return smoothed


def root_positions(
    relative: FloatArray, template: Template, carried: FloatArray | None = None, standing: bool = False
) -> FloatArray:
    """(T, 3) world root positions from joint positions relative to the root (T, J, 3): the
    lowest foot point sits at the training contact height and is pinned while it is the
    lowest (:func:`mse.motion.base.contacts.root_track`); ``carried`` (T, 4): in flight
    phases the root keeps that velocity and lift instead. ``standing`` (one-shot actions):
    the lowest point of either foot is pinned, without the walks' hysteresis (see
    :data:`STANDING_PIN`)."""
    contacts = template.contacts[0] + template.contacts[1]
    feet = [list(range(len(template.contacts[0]))), list(range(len(template.contacts[0]), len(contacts)))]
    if standing and STANDING_PIN:
        return root_track(
            relative, contacts, template.contact_height, template.frame_time, carried, feet, hysteresis=0.0
        )
    return root_track(relative, contacts, template.contact_height, template.frame_time, carried, groups=feet)


def smoothed(
    statics: FloatArray, model: HsmmModel, carried: FloatArray | None = None
) -> tuple[FloatArray, FloatArray | None]:
    """The generated trajectories low-passed (:data:`OUTPUT_CUTOFF_HZ`; a standing action's
    legs more, :func:`still_legs`), as :func:`statics_to_motion` plays them."""
    template = model.template
    # MLPG + GV trajectories keep a little frame-to-frame ripple at the state boundaries;
    # through the pinned feet it reaches the whole body: Bandai dataset 2 walks had head and
    # wrist jerk 2.3-2.6x the real walks' (limit 2x); at 6 Hz 0.8-1.2x, speed and stride kept.
    statics = zero_phase_lowpass(statics, template.frame_time, OUTPUT_CUTOFF_HZ)
    if not model.travels and template.feet_lift <= ACTING_LEGS_LIFT:  # standing, on both feet
        statics = still_legs(statics, template)
    if carried is not None:
        carried = smooth_carried(carried, template.frame_time, OUTPUT_CUTOFF_HZ)
    return statics, carried


def rested_statics(
    statics: FloatArray, carried: FloatArray | None, model: HsmmModel, frames: int
) -> tuple[FloatArray, FloatArray | None]:
    """The first ``frames`` of a clip generated at its own length, smoothed and eased into its
    last pose (:func:`mse.motion.base.loop.rested`), facing where the body faces when the
    ease starts. Smoothed after the ease, the filters' odd padding carried the ease's speed
    into the last frame (Bandai dataset 1 byebye at 0.3 of its take: 29 cm/s)."""
    frame_time = model.template.frame_time
    statics, carried = smoothed(statics, model, carried)
    start = max(0, frames - rest_ease_frames(frames, frame_time) - 1)
    rest = facing_as(statics[-1], statics[start], model.template)
    carried = rested(carried, frames, frame_time) if carried is not None else None
    return rested(statics, frames, frame_time, rest), carried


def statics_to_motion(
    statics: FloatArray, model: HsmmModel, carried: FloatArray | None = None, smooth: bool = True
) -> Motion:
    """BVH motion from static features: rotations, template offsets, recomputed root
    (``carried``: per-frame flight phases, :mod:`mse.motion.hsmm.carried`); ``smooth=False``
    when they are already :func:`smoothed`."""
    template = model.template
    skeleton = template.skeleton
    frames = statics.shape[0]
    if smooth:
        statics, carried = smoothed(statics, model, carried)
    standing = not model.travels  # one-shot actions and hand cycles (waves)
    rotations = local_rotations_from_features(statics, template)
    translations = np.broadcast_to(template.translations, (frames, skeleton.joint_count, 3)).copy()
    translations[:, template.root_joint] = 0.0
    positions, world = forward_kinematics(skeleton.parents, translations, rotations)
    path = path_yaws(model, frames)
    if path is not None:
        # turning locomotion: the features face the path; the path turns at the model's rate
        rotations, carried = _turned_along(path, rotations, world, carried, template)
        positions, world = forward_kinematics(skeleton.parents, translations, rotations)
    root_world = positions[:, template.root_joint]
    relative = positions - root_world[:, None, :]
    target = root_positions(relative, template, carried, standing=standing)
    if model.travels:  # the hips never go back (forward_only)
        hips = relative[:, list(template.legs)].mean(axis=1)  # the hips' midpoint from the root
        target = forward_only(target, hips, path)
    parent = skeleton.parents[template.root_joint]
    local = (
        np.einsum("fba,fb->fa", world[:, parent], target - root_world) if parent >= 0 else target
    )
    translations[:, template.root_joint] = local
    values = np.zeros((frames, skeleton.channel_count))
    for joint in range(skeleton.joint_count):
        columns = skeleton.position_columns(joint)
        if columns:
            values[:, list(columns)] = translations[:, joint]
        order = skeleton.rotation_order(joint)
        if len(order) == 3:
            values[:, list(skeleton.rotation_columns(joint))] = matrix_to_euler(
                rotations[:, joint], order
            )
    return Motion(skeleton, template.frame_time, values)


def forward_only(target: FloatArray, hips: FloatArray, path: FloatArray | None = None) -> FloatArray:
    """``target`` (T, 3) root positions moved so that the hips' midpoint (``target + hips``)
    never goes back along the clip's direction of travel (the mean of its horizontal moves,
    in the path's heading frame ``path`` when it turns): the progress along that direction
    becomes its nearest non-decreasing sequence (isotonic regression), the rest of each move
    is kept.

    Real Bandai locomotion never moves its hips backwards in a frame; generated steps did, by
    pinning the stance foot through a stance change (dataset 1 walk-back feminine: 5 frames of
    every step, up to 2.0 cm per frame), at the clip's first and last frames (the filters'
    edges: a dash's first frame 1.0 cm) and in the last step's close at 2x and 3x length
    (walk-right tired: 8 frames, 2.6 cm). Where the progress is flattened the stance foot
    slides by what the hips would have gone back."""
    from mse.motion.base.heading import in_heading_frame

    with require("motion"):
        from scipy.optimize import isotonic_regression

    if len(target) < 3:
        return target
    centre = target + hips
    moves = np.diff(centre[:, [0, 2]], axis=0)
    yaws = 0.5 * (path[1:] + path[:-1]) if path is not None else np.zeros(len(moves))
    local = in_heading_frame(moves, yaws)
    travel = local.sum(axis=0)
    norm = float(np.linalg.norm(travel))
    if norm < 1e-9:
        return target
    direction = travel / norm
    along = local @ direction
    if along.min() >= 0.0:
        return target
    progress = np.concatenate([[0.0], np.cumsum(along)])
    monotone = isotonic_regression(progress).x
    corrected = local + (np.diff(monotone) - along)[:, None] * direction[None, :]
    world_moves = in_heading_frame(corrected, -yaws)
    shift = np.zeros_like(target)
    shift[1:, [0, 2]] = np.cumsum(world_moves - moves, axis=0)
    result: FloatArray = target + shift
    return result


def path_yaws(model: HsmmModel, frames: int) -> FloatArray | None:
    """(frames,) the heading of a turning model's path (``info["turn_rate"]`` radians per
    second, centred on the clip as the training clips' alignment is), or None."""
    rate = model.info.get("turn_rate")
    if not model.template.turning or not isinstance(rate, int | float):
        return None
    times = (np.arange(frames, dtype=np.float64) - 0.5 * (frames - 1)) * model.template.frame_time
    return np.asarray(float(rate) * times, dtype=np.float64)


def _turned_along(
    path: FloatArray, rotations: FloatArray, world: FloatArray, carried: FloatArray | None, template: Template
) -> tuple[FloatArray, FloatArray | None]:
    """The root's local rotations (and the carried velocities) turned by ``path`` frame by
    frame about the vertical (in the frame of the root's static parent, as the alignment)."""
    root = template.root_joint
    parent = template.skeleton.parents[root]
    frame = world[0, parent] if parent >= 0 else np.eye(3)
    turns = yaw_matrix(path)
    rotations = rotations.copy()
    rotations[:, root] = frame.T[None] @ turns @ frame[None] @ rotations[:, root]
    if carried is not None:
        carried = carried.copy()
        x, z = carried[:, 0].copy(), carried[:, 1].copy()
        carried[:, 0] = turns[:, 0, 0] * x + turns[:, 0, 2] * z
        carried[:, 1] = turns[:, 2, 0] * x + turns[:, 2, 2] * z
    return rotations, carried


def swings_span(model: HsmmModel, names: list[str], frames: int, seed: int | None) -> tuple[int, int] | None:
    """The frames of a hand cycle's swings as :func:`generate` lays them out for ``names``
    over ``frames``: from the end of the rise (the first unit) to the start of the fall (the
    last), an even number of swings (units alternate sides; each ends at a turn of the sway);
    None when fewer than two swings. The return from the rise (``second``) is one of them: a
    feminine wave has few, long swings (first, second, one inner, last), and without it the
    loop had no whole swing to repeat.

    Left to :func:`mse.motion.base.loop.loop_span` (the two frames whose poses join best), a
    wave whose swings alternate with holds repeated a hold: a feminine one-hand wave made
    from Bandai dataset 2's waves held still for 13 s at twice its length (its takes hold at
    most 7.4 s) and swung 0.13 times per second (its takes 0.23-0.55)."""
    units = [model.unit(name) for name in names]
    swings = len(units) - 2
    swings -= swings % 2
    if swings < 2:
        return None
    rng = np.random.default_rng(seed) if seed is not None else None
    durations = state_durations(units, frames, rng)  # as generate() draws them
    bounds = np.cumsum([0] + [u.states for u in units])
    ends = np.cumsum([int(durations[bounds[k] : bounds[k + 1]].sum()) for k in range(len(units))])
    return int(ends[0]), int(ends[swings])


#: a cycle requested this much longer than its clips repeats, a one-shot action rests (base.loop)
LOOP_RATIO = 1.3


def _natural_frames(model: HsmmModel) -> int:
    """The median length of the clips the model was trained or adapted on (0: unknown)."""
    value = model.info.get("frames")
    return int(value) if isinstance(value, int | float) and value > 0 else 0


def synthesize(
    model: HsmmModel,
    steps: int | None = None,
    duration_s: float | None = None,
    gv: bool = True,
    seed: int | None = None,
) -> Motion:
    """A new clip: ``steps`` steps at natural speed, or exactly ``duration_s`` seconds."""
    frame_time = model.template.frame_time
    if duration_s is not None and not 0 < duration_s <= MAX_MOTION_SECONDS:
        raise ValueError(f"a clip lasts at most {MAX_MOTION_SECONDS:g} s, not {duration_s!r}")
    if steps is not None and not 0 < steps <= MAX_STEPS:
        raise ValueError(f"a clip has 1 to {MAX_STEPS} steps, not {steps!r}")
    if duration_s is not None:
        requested = max(1, round(duration_s / frame_time))
        names = plan_units(model, steps=steps, frames=requested)
    else:
        names = plan_units(model, steps=steps)
        requested = round(sum(float(model.unit(n).duration_means.sum()) for n in names))
    if requested * frame_time > MAX_MOTION_SECONDS:
        raise ValueError(f"{requested} frames would last more than {MAX_MOTION_SECONDS:g} s")
    natural = _natural_frames(model)
    period = model.info.get("period_s", 0.0)
    period_s = float(period) if isinstance(period, int | float) else 0.0
    if duration_s is not None and natural and shorter_than_a_cycle(requested, natural, frame_time, period_s):
        # shorter than one cycle (a one-shot action: than its clips): generated at their
        # length and ended on its rest pose (base.loop.rested, as LMA + HMM). Planned for the
        # request, a run of 7 frames (0.3 of its cycle) dropped to its first unit and
        # stopped mid-stride (53 cm from the take's last pose, 124 cm/s in its last frame),
        # and a one-shot was played whole, faster (a kick at 0.3 of its take: jerk 7x its take's)
        names = plan_units(model, frames=natural)
        statics, carried = generate(model, names, natural, gv=gv and model.cycle != "hands", seed=seed)
        statics, carried = rested_statics(statics, carried, model, requested)
        return statics_to_motion(statics, model, carried, smooth=False)
    # Short requests drop inner units until every state can have a frame.
    while len(names) > 1 and requested < model.states * len(names):
        names = names[:-2] + names[-1:] if len(names) > 2 else names[:1]
    frames = max(requested, model.states)
    if model.cycle == "hands" and natural and frames >= LOOP_RATIO * natural:
        # a hand cycle longer than its clips: generated at their length, its swings repeated
        # at their tempo (base.loop): planned for the whole length, the units between the
        # rise and the fall were the holds between a feminine wave's swings, and the wave's
        # amplitude fell from 5.9 cm at the takes' length to 3.3 at 3x (real 7.2-8.2)
        names = plan_units(model, frames=natural)
        statics, _ = generate(model, names, natural, gv=False, seed=seed)
        span = swings_span(model, names, natural, seed)
        return statics_to_motion(looped(statics, frames, frame_time, period_s=period_s, stretch=span), model)
    if not model.cyclic and natural and frames >= LOOP_RATIO * natural:
        # a one-shot action longer than its clips: at their tempo, then at rest (base.loop)
        statics, _ = generate(model, names, natural, gv=gv, seed=seed)
        return statics_to_motion(held(statics, frames), model)
    # Hand cycles (waves) skip GV: each swing is a unit of its own, and GV widened them
    statics, carried = generate(model, names, frames, gv=gv and model.cycle != "hands", seed=seed)
    if frames != requested:  # fewer frames than states: sample the trajectory evenly
        kept = np.round(np.linspace(0, frames - 1, requested)).astype(np.int64)
        statics = statics[kept]
        carried = carried[kept] if carried is not None else None
    return statics_to_motion(statics, model, carried)

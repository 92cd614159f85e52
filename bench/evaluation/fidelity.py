"""Action fidelity: does a clip perform its action, and is its motion clean?

Measures are computed on world joint positions (forward kinematics), in the clip's own body
frame (first-frame hips: X to the body's left, Y up, Z forward; file units, cm for Bandai and
the starter) so that performers facing different ways compare:

=====================  ================================================================
``head_dip``           head height: 95th percentile minus minimum (a bow dips the head)
``head_forward``       head travel forward of the feet: maximum minus 5th percentile
``hand_to_head``       closest approach of a wrist to the head over the clip
``wrists_over_head``   highest frame of the *lower* wrist, relative to the head top
``hand_range``         largest range of motion of a wrist relative to the chest: the
                       largest distance between two of its positions (holding a pose it
                       has been in, e.g. the rest pose after a longer request, leaves it
                       unchanged; the distance from the mean position did not: it grew with
                       the share of the clip spent at rest)
``wave_frequency``     side-to-side cycles per second of the wrists (relative to the chest)
``wave_amplitude``     their peak-to-peak amplitude
``forward_speed``      root travel along the first-frame forward axis per second
``side_speed``         root travel to the body's left (first frame) per second
``step_rate``          steps per second: alternating extrema of the feet's separation along
                       its main horizontal axis (heel strikes), over the time they span
``backward``           largest distance the root moves in one frame against the clip's
                       direction of travel (start to end; on a turning path, the mean
                       direction in the path's heading frame, which turns with it)
``turn_rate``          degrees per second the hips' facing turns (least-squares slope)
``foot_slip``          median horizontal speed of the lowest foot point while it is on the
                       floor (within 2 cm of its lowest height): the stance foot
``jerk``               RMS jerk of head and wrists (third differences of positions)
``reversals``          share of moving frames where a wrist's velocity turns back by more
                       than 90 degrees from one frame to the next (jitter)
``bone_error``         largest relative change of a bone length over the clip
=====================  ================================================================

A clip that turns (at least :data:`mse.motion.base.heading.TURN_DEG_PER_S`) is measured along
its path: speeds, steps and the direction of travel in the path's heading frame
(:func:`mse.motion.base.heading.heading_track`), frame by frame; a straight line from start to
end, or the first frame's axes, would count a turning walk's steps as slower, its speed as
lower and its hips as going backwards on the far side of the turn.

Which measures say that a clip *performs* an action, and their admitted spread, come from
the real clips of that action (:func:`reference`): :data:`ACTION_SIGNATURES` names them
for the actions whose gist is known (bow: head dip and forward travel; hand to mouth: wrist
near the head; raise hands: wrists over the head; wave: frequency and amplitude; walks:
forward progress); any other action is checked on the ranges that every one of its real
clips covers (wrist range of motion, head dip, head forward travel: those of at least
:data:`TELLING_SHARE` arm lengths). Quality is checked for every action: foot slip and jerk
at most :data:`QUALITY_FACTOR` times the real clips' median, bone lengths constant.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from mse.motion.base.body_frame import body_of
from mse.motion.base.bvh import Motion
from mse.motion.base.cycles import TRAVEL_LEG_LENGTHS_PER_S, action_shape, step_boundaries, travel_rate
from mse.motion.base.heading import TURN_DEG_PER_S, facing_yaws, in_heading_frame, smoothed_yaws
from mse.motion.base.kinematics import FloatArray
from mse.motion.base.loop import EDGE_SHARE, held, looped

MEASURES: tuple[str, ...] = (
    "head_dip",
    "head_forward",
    "hand_to_head",
    "wrists_over_head",
    "hand_range",
    "wave_frequency",
    "wave_amplitude",
    "forward_speed",
    "side_speed",
    "step_rate",
    "backward",
    "turn_rate",
    "foot_slip",
    "jerk",
    "reversals",
    "bone_error",
)

#: The measures that say an action is performed, per action (others: :data:`DEFAULT_SIGNATURE`).
ACTION_SIGNATURES: Mapping[str, tuple[str, ...]] = {
    "bow": ("head_dip", "head_forward"),
    "head_down": ("head_dip",),
    "lean_forward": ("head_forward",),
    "hand_on_mouth": ("hand_to_head",),
    "hand_on_face": ("hand_to_head",),
    "arms_raised": ("wrists_over_head",),
    "raise-up-both-hands": ("wrists_over_head",),
    "wave-both-hands": ("wave_frequency", "wave_amplitude"),
    "walk": ("forward_speed",),
    "walk-back": ("forward_speed",),
    "walk-left": ("side_speed",),
    "walk-right": ("side_speed",),
    "run": ("forward_speed",),
    "dash": ("forward_speed",),
}
#: candidates for the actions without a named signature: the ranges every real clip of the
#: action covers by at least :data:`TELLING_SHARE` arm lengths are its signature (else the
#: candidate with the largest minimum)
DEFAULT_CANDIDATES: tuple[str, ...] = ("hand_range", "head_dip", "head_forward")
TELLING_SHARE = 0.2
#: foot slip and jerk may be this many times the real clips' median
QUALITY_FACTOR = 2.0
#: the admitted spread of an action measure: the real clips' range, each end moved out by
#: this share of its size
SPREAD_MARGIN = 0.15
#: the medians that foot slip is compared with are at least this many arm lengths per second
#: (a standing performer's feet "slide" 0.1-0.5 cm/s in the capture noise)
SLIP_FLOOR_ARM_LENGTHS = 0.01
#: the largest backward step of the root admitted is at least this many arm lengths (about
#: 1.2 mm for a Bandai performer: the LMA + HMM normal walk of dataset 2 at twice its length
#: stepped back 0.4 mm in its first frames, where the real walks never do; the failures this
#: check is for were steps of centimetres, up to 6.4 cm). Real Bandai takes measured the same
#: way step back 0.00 cm in every frame (every travelling action of dataset 1, 15-30 takes
#: each; dataset 2's walks), so this floor is the limit. The direction of travel is the
#: clip's start to end: the heading of these straight takes (a take that turns would need
#: the heading frame by frame, as base.contacts.travel_directions takes it)
BACKWARD_FLOOR_ARM_LENGTHS = 0.002
#: bones may stretch by this share at most
BONE_TOLERANCE = 0.01
_CONTACT_BAND = 2.0  # cm above a foot's lowest point still counts as on the floor
_WAVE_WINDOW_S = 1.0  # detrending window of the wave measures


def _wave(relative: FloatArray, frame_time: float) -> tuple[float, float]:
    """(cycles per second, peak-to-peak amplitude) of a side-to-side signal."""
    frames = len(relative)
    window = max(3, round(_WAVE_WINDOW_S / frame_time) | 1)
    if frames < window + 4:
        return 0.0, 0.0
    kernel = np.ones(window) / window
    padded = np.pad(relative, (window // 2, window // 2), mode="edge")
    detrended = relative - np.convolve(padded, kernel, mode="valid")
    spread = float(np.std(detrended))
    if spread < 1e-9:
        return 0.0, 0.0
    threshold = 0.5 * spread
    crossings, side = 0, 0
    for value in detrended:  # zero crossings with hysteresis
        now = 1 if value > threshold else -1 if value < -threshold else 0
        if now and side and now != side:
            crossings += 1
        side = now or side
    frequency = 0.5 * crossings / (frames * frame_time)
    return frequency, 2.0 * np.sqrt(2.0) * spread


def _step_rate(separation: FloatArray, frame_time: float) -> float:
    """Steps per second from (F, 2) horizontal foot-to-foot vectors: the alternating extrema
    of their projection on the main axis (heel strikes), over the time from first to last."""
    if len(separation) < 4:
        return 0.0
    centred = separation - separation.mean(axis=0)
    _, _, axes = np.linalg.svd(centred, full_matrices=False)
    strikes = step_boundaries(centred @ axes[0], max(2, round(0.15 / frame_time)))
    if len(strikes) < 2:
        return 0.0
    return (len(strikes) - 1) / ((strikes[-1] - strikes[0]) * frame_time)


def step_rate_along_path(separation: FloatArray, yaws: FloatArray, frame_time: float) -> float:
    """:func:`_step_rate` of (F, 2) foot-to-foot vectors expressed in each frame's heading
    frame (``yaws``: the path's heading, :func:`mse.motion.base.heading.smoothed_yaws`): on a
    turning path the separation turns with the walker, and along one fixed axis the strikes
    of the steps across it were lost."""
    return _step_rate(in_heading_frame(separation, yaws), frame_time)


def _diameter(points: FloatArray, chunk: int = 512) -> float:
    """The largest distance between two of ``points`` (N, 3), in chunks of rows (a one-minute
    clip at 60 fps would otherwise need a 3,600 x 3,600 x 3 array)."""
    widest = 0.0
    for start in range(0, len(points), chunk):
        block = points[start : start + chunk]
        widest = max(widest, float(np.max(np.linalg.norm(block[:, None] - points[None], axis=-1))))
    return widest


def _bones(motion: Motion) -> float:
    """Largest relative change of a bone length; the bones to joints whose position channels
    move (the root's translation, e.g. Bandai's joint_Root -> Hips) are no bones."""
    positions = motion.positions()
    skeleton = motion.skeleton
    translations = motion.translations()
    worst = 0.0
    for joint, parent in enumerate(skeleton.parents):
        if parent < 0:
            continue
        if skeleton.position_columns(joint) and float(np.ptp(translations[:, joint], axis=0).max()) > 1e-6:
            continue
        length = np.linalg.norm(positions[:, joint] - positions[:, parent], axis=-1)
        typical = float(np.median(length))
        if typical > 1e-6:
            worst = max(worst, float(np.max(np.abs(length - typical))) / typical)
    return worst


def measure(motion: Motion, path: str = "<motion>") -> dict[str, float]:
    """Every measure of :data:`MEASURES` for one clip."""
    data = body_of(motion, path)
    p, dt, body = data.positions, data.frame_time, data.body
    head = p[:, body.head]
    hands = p[:, [body.left_hand, body.right_hand]]  # (F, 2, 3)
    chest = p[:, data.chest]
    feet = p[:, list(data.feet)]
    feet_centre_z = feet[:, :, 2].mean(axis=1)
    values: dict[str, float] = {}
    values["head_dip"] = float(np.percentile(head[:, 1], 95) - head[:, 1].min())
    forward = head[:, 2] - feet_centre_z
    values["head_forward"] = float(forward.max() - np.percentile(forward, 5))
    values["hand_to_head"] = float(np.min(np.linalg.norm(hands - head[:, None], axis=-1)))
    values["wrists_over_head"] = float(np.max(hands[:, :, 1].min(axis=1) - head[:, 1]))
    relative = hands - chest[:, None]
    values["hand_range"] = float(max(_diameter(relative[:, k]) for k in (0, 1)))
    waves = [_wave(relative[:, k, 0], dt) for k in (0, 1)]
    values["wave_frequency"] = float(np.mean([w[0] for w in waves]))
    values["wave_amplitude"] = float(np.mean([w[1] for w in waves]))
    root = 0.5 * (p[:, body.left_hip] + p[:, body.right_hip])
    span = max(motion.duration - dt, dt)
    facing = facing_yaws(p, body.left_hip, body.right_hip)
    times = np.arange(len(facing)) * dt
    turn = float(np.degrees(np.polyfit(times, facing, 1)[0])) if len(facing) >= 3 else 0.0
    values["turn_rate"] = turn
    separation = feet[:, 0, [0, 2]] - feet[:, len(data.feet) // 2, [0, 2]]
    moves = np.diff(root[:, [0, 2]], axis=0)  # (F-1, 2) as (x, z)
    if abs(turn) >= TURN_DEG_PER_S:  # along the path (see the module)
        path = smoothed_yaws(facing, dt)
        moves = in_heading_frame(moves, 0.5 * (path[1:] + path[:-1]))
        values["step_rate"] = step_rate_along_path(separation, path, dt)
    else:
        values["step_rate"] = _step_rate(separation, dt)
    travel = moves.sum(axis=0)
    values["forward_speed"] = float(travel[1] / span)
    values["side_speed"] = float(travel[0] / span)
    norm = float(np.linalg.norm(travel))
    along = moves @ (travel / norm) if norm > 1e-9 else np.zeros(1)
    values["backward"] = float(max(0.0, -float(np.min(along)))) if along.size else 0.0
    lowest = np.argmin(feet[:, :, 1], axis=1)
    floor = feet[:, :, 1].min(axis=0)  # each foot point's lowest height
    point = feet[np.arange(len(feet)), lowest]  # (F, 3)
    on_floor = point[:, 1] <= floor[lowest] + _CONTACT_BAND
    same = lowest[1:] == lowest[:-1]
    horizontal = np.linalg.norm(np.diff(point[:, [0, 2]], axis=0), axis=-1) / dt
    stance = same & on_floor[1:] & on_floor[:-1]
    values["foot_slip"] = float(np.median(horizontal[stance])) if stance.any() else 0.0
    effectors = np.concatenate([head[:, None], hands], axis=1)
    if len(effectors) >= 4:
        jerk = np.diff(effectors, n=3, axis=0) / dt**3
        values["jerk"] = float(np.sqrt(np.mean(np.sum(jerk**2, axis=-1))))
    else:
        values["jerk"] = 0.0
    velocity = np.diff(hands, axis=0) / dt  # (F-1, 2, 3)
    speed = np.linalg.norm(velocity, axis=-1)
    moving = (speed[1:] > 0.05 * data.scale) & (speed[:-1] > 0.05 * data.scale)
    turned = np.sum(velocity[1:] * velocity[:-1], axis=-1) < 0.0
    values["reversals"] = float(np.mean(turned[moving])) if moving.any() else 0.0
    values["bone_error"] = _bones(motion)
    return values


@dataclass(frozen=True, slots=True)
class Reference:
    """What real clips of one action do: per measure, the values of the real clips, and
    their performers' arm length (file units)."""

    action: str
    values: Mapping[str, tuple[float, ...]]
    scale: float
    #: the real clips travel (:func:`mse.motion.base.cycles.travel_rate`): their step rate
    #: is checked too, and no frame may move the root backwards more than theirs do
    travels: bool = False

    @property
    def signature(self) -> tuple[str, ...]:
        turning = (("turn_rate",) if self.turns else ())
        named = ACTION_SIGNATURES.get(self.action)
        if named is not None:
            return named + (("step_rate",) if self.travels else ()) + turning
        if self.travels:  # a travelling action of the user's own: its main direction of travel
            speeds = ("forward_speed", "side_speed")
            main = max(speeds, key=lambda name: abs(self.median(name)))
            return (main, "step_rate", *turning)
        lows = {name: min(self.values[name]) for name in DEFAULT_CANDIDATES}
        telling = tuple(name for name in DEFAULT_CANDIDATES if lows[name] >= TELLING_SHARE * self.scale)
        return telling or (max(lows, key=lambda name: lows[name]),)

    @property
    def turns(self) -> bool:
        """The real clips turn as they travel (:data:`mse.motion.base.heading.TURN_DEG_PER_S`)."""
        return self.travels and abs(self.median("turn_rate")) >= TURN_DEG_PER_S

    def spread(self, name: str) -> tuple[float, float]:
        """The admitted range of an action measure: the real range, each end moved out by
        :data:`SPREAD_MARGIN` of its own size."""
        values = np.asarray(self.values[name])
        low, high = float(values.min()), float(values.max())
        return low - SPREAD_MARGIN * abs(low), high + SPREAD_MARGIN * abs(high)

    def median(self, name: str) -> float:
        return float(np.median(self.values[name]))


def reference(action: str, clips: Iterable[Motion]) -> Reference:
    """The reference of ``action`` from its real clips."""
    motions = list(clips)
    if not motions:
        raise ValueError(f"no real clip of {action!r}")
    measured = [measure(m) for m in motions]
    scale = float(np.median([body_of(m).scale for m in motions]))
    travels = float(np.median([travel_rate(m) for m in motions])) >= TRAVEL_LEG_LENGTHS_PER_S
    return Reference(action, {name: tuple(m[name] for m in measured) for name in MEASURES}, scale, travels)


#: measures of a standing cycle that depend on the clip's length (see :func:`repeated`)
CYCLE_MEASURES = ("wave_frequency", "wave_amplitude")


def repeated(action_reference: Reference, motions: Sequence[Motion], factor: float) -> Reference:
    """``action_reference`` for clips ``factor`` times longer than the real ones, as the
    methods make them (:mod:`mse.motion.base.loop`): when the real clips cycle by their hands
    (:func:`mse.motion.base.cycles.action_shape`), the values of :data:`CYCLE_MEASURES` are
    those of the real clips with their cycles repeated at their tempo (measured over a whole
    take, a feminine wave's amplitude is mostly its rise and fall: 7.2-8.2 cm; the swings
    between, 1.6-2.5); when they do not cycle, the values of :data:`DEFAULT_CANDIDATES` are
    those of the real clips followed by their rest pose (the measures take percentiles and
    means over the clip). Travelling actions' measures are rates: unchanged."""
    if factor <= 1.0:
        return action_reference
    shape = action_shape(list(motions))
    if shape.travels:
        return action_reference
    if shape.cycle == "hands":
        names: tuple[str, ...] = CYCLE_MEASURES
        longer = [
            replace(m, values=looped(m.values, round(factor * m.frame_count), m.frame_time, EDGE_SHARE, shape.period_s))
            for m in motions
        ]
    else:
        names = (*DEFAULT_CANDIDATES, "hand_to_head", "wrists_over_head")
        longer = [replace(m, values=held(m.values, round(factor * m.frame_count))) for m in motions]
    measured = [measure(m) for m in longer]
    values = dict(action_reference.values)
    for name in names:
        values[name] = tuple(m[name] for m in measured)
    return replace(action_reference, values=values)


@dataclass(frozen=True, slots=True)
class Check:
    """One check of one clip: the measure, its value, the admitted range, passed or not."""

    name: str
    value: float
    low: float
    high: float

    @property
    def passed(self) -> bool:
        return self.low <= self.value <= self.high


def check(
    values: Mapping[str, float],
    action_reference: Reference,
    style_reference: Reference | None = None,
) -> list[Check]:
    """The action checks (spread of ``action_reference``) and the quality checks: foot slip
    and jerk at most :data:`QUALITY_FACTOR` times the larger of the medians of the style's
    real clips and of the action's (a slow style's clip generated on a faster desired path
    is not held to the slow style's jerk alone), foot slip against at least
    :data:`SLIP_FLOOR_ARM_LENGTHS`."""
    checks = []
    for name in action_reference.signature:
        low, high = action_reference.spread(name)
        checks.append(Check(name, values[name], low, high))
    floors = {"foot_slip": SLIP_FLOOR_ARM_LENGTHS * action_reference.scale, "jerk": 0.0}
    for name in ("foot_slip", "jerk"):
        medians = [action_reference.median(name)]
        if style_reference is not None:
            medians.append(style_reference.median(name))
        limit = QUALITY_FACTOR * max(*medians, floors[name])
        checks.append(Check(name, values[name], -np.inf, limit))
    if action_reference.travels:
        # no frame moves the root against the direction of travel by more than a real take does
        # (Bandai walks: never; a floor of BACKWARD_FLOOR_ARM_LENGTHS for rounding-level noise)
        limit = max(max(action_reference.values["backward"]), BACKWARD_FLOOR_ARM_LENGTHS * action_reference.scale)
        checks.append(Check("backward", values["backward"], -np.inf, limit))
    checks.append(Check("bone_error", values["bone_error"], -np.inf, BONE_TOLERANCE))
    return checks


def failed(checks: Sequence[Check]) -> list[Check]:
    return [c for c in checks if not c.passed]

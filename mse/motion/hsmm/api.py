"""Library API of the HSMM method: train, adapt, synthesize.

``train_average`` builds the average model of an action over (motion, style) clips with
style-adaptive training; ``adapt_model`` adapts it to a style from a few takes or labelled
steps (CMLLR, then MAP); ``train_scratch`` is the no-prior baseline; ``synthesize`` generates
a clip.  Training from a motion library and the cached leaf entry point of ``animate`` are in
:mod:`mse.motion.hsmm.leaf`.
"""

from __future__ import annotations

import contextlib
import functools
import importlib
from collections.abc import Callable, Iterator, Sequence
from dataclasses import asdict, dataclass, replace
from typing import ParamSpec, TypeVar

import numpy as np

from mse.motion.base.bvh import Motion
from mse.motion.base.cycles import ActionShape, action_shape
from mse.motion.base.heading import turn_rate, turning_rate
from mse.motion.hsmm.adapt import adapt_units, adaptive_training, auto_blocks, blocks_for
from mse.motion.hsmm.carried import carried_profiles
from mse.motion.hsmm.features import FloatArray
from mse.motion.hsmm.instances import (
    Segmentation,
    clip_instances,
    cycle_signal,
    gather_instances,
    segment_motion,
)
from mse.motion.hsmm.mlpg import global_variance
from mse.motion.hsmm.model import HsmmModel, Instance, train_units, variance_floor
from mse.motion.hsmm.prep import Template, build_template
from mse.motion.hsmm.synth import synthesize as _synthesize

__all__ = [
    "Options",
    "Segmentation",
    "adapt_model",
    "clip_instances",
    "cycle_signal",
    "segment_motion",
    "synthesize",
    "train_average",
    "train_scratch",
]


@dataclass(frozen=True, slots=True)
class Options:
    """Training and adaptation settings (defaults are the documented ones)."""

    states: int = 5
    iterations: int = 4
    sat_rounds: int = 2
    blocks: str = "stream"  # SAT's CMLLR regression blocks: stream (static/Δ/Δ²), joint, full
    adapt_blocks: str = "auto"  # adaptation's blocks; auto: by the amount of data (auto_blocks)
    prior: float = 1.0  # weight of the identity prior of CMLLR rows
    tau: float | None = None  # MAP prior weight of output Gaussians (frames); None: one visit
    tau_duration: float = 1.0  # MAP prior weight of duration Gaussians (unit instances)
    use_map: bool = True
    soft: bool = True  # occupancy-weighted (forward-backward) adaptation statistics
    regression_classes: bool = True  # per-leg CMLLR transforms when the data allows
    unit_classes: bool = False  # and per-unit transforms below them (a third tree level)
    # Hand cycles (waves): regression classes by context (rise / swings / fall), small
    # ones with per-joint static blocks (adapt.adapt_units, adapt.class_blocks).
    context_classes: bool = True
    soft_training: bool = False  # occupancy-weighted training (average and scratch models)
    style_gv_spread: bool = True  # adapted GV variance from the style's data, not the average's
    gv_tau: float = 0.05  # weight of the average model's global variance when adapting
    # Locomotion's adaptation leaves the root joint's rotation (its heading) out of the
    # stream blocks, in a 3×3 block of its own: regressed on the whole pose (66 columns from
    # one take's 221 frames), the root of the adapted Bandai dataset 1 feminine walk-right
    # turned with the pose (first state -6.8° about the vertical where the take has +0.2°),
    # its first frame faced 6° off the take's and its side speed, measured in that frame,
    # was -10.9 cm/s (the take -19.1; now -16.8). Standing actions keep it in the pose's
    # blocks: their root's tilt is the bow or the lean, and on its own the adapted normal
    # punch leant 28 cm forward (its take 13.6) and the musical bow 34 (spread to 32.9).
    root_block: bool = True


@contextlib.contextmanager
def single_threaded_blas() -> Iterator[None]:
    """Pin BLAS to one thread: the matrices are small, and threads only contend."""
    try:
        threadpoolctl = importlib.import_module("threadpoolctl")
    except ImportError:  # comes with scikit-learn; without it, run as configured
        yield
        return
    with threadpoolctl.threadpool_limits(limits=1, user_api="blas"):
        yield


_P = ParamSpec("_P")
_R = TypeVar("_R")


def one_blas_thread(func: Callable[_P, _R]) -> Callable[_P, _R]:
    """Decorator: run ``func`` with BLAS pinned to one thread."""

    @functools.wraps(func)
    def wrapper(*args: _P.args, **kwargs: _P.kwargs) -> _R:
        with single_threaded_blas():
            return func(*args, **kwargs)

    return wrapper


#: Synthesis is cheap and pins nothing (threadpoolctl's probe alone would cost more).
synthesize = _synthesize


def _first_leg(instances: Sequence[Instance]) -> str:
    legs = [i.unit.rpartition("-")[2] for i in instances if i.unit.startswith("first-")]
    return max(("a", "b"), key=legs.count) if legs else "a"


def _last_units(instances: Sequence[Instance]) -> dict[str, list[str]]:
    """``{"last_units": [...]}``: the units the clips end on (a cyclic action's ``last-*``),
    so that a plan ends as the clips do (:func:`mse.motion.hsmm.synth.plan_units`)."""
    ends = sorted({i.unit for i in instances if i.unit.startswith("last-")})
    return {"last_units": ends} if ends else {}


def _gv_stats(statics: Sequence[FloatArray]) -> tuple[FloatArray, FloatArray]:
    values = np.array([global_variance(s) for s in statics])
    mean = values.mean(axis=0)
    var = np.maximum(values.var(axis=0), (0.1 * mean) ** 2 + 1e-12)
    return mean, var


#: one-shot actions get one state per this many frames of their typical length (a step unit
#: of a Bandai walk has 5 states over 15-20 frames), between ``Options.states`` and
#: :data:`MAX_STATES`
FRAMES_PER_STATE = 4
#: The cap was 60 while the alignment lattice took O(S·L²) memory (1.7 GB for the 63 s
#: Bandai dance at 60 states): the dance was drawn through a pose per second, generated
#: without GV it crouched 71 cm where the take crouches 85.5, and GV, restoring the take's
#: variance to that coarse path, deepened the crouch to 100 (spread to 98.3). With the
#: lattice bounded (:data:`mse.motion.hsmm.model.RUN_SPAN`) the dance gets its 475 states
#: (adapted, GV on: 87.3). What bounds the states now is the adaptation statistics (a full
#: scatter matrix per state, 0.3 MB on Bandai's 198-dimensional observations: 150 MB at
#: the cap).
MAX_STATES = 500


def unit_states(cyclic: bool, lengths: Sequence[int], options: Options) -> int:
    """States per unit: ``options.states`` for steps; for a one-shot action, scaled to the
    action's median length, so that a 4-second bow is not drawn through 5 poses."""
    if cyclic or not lengths:
        return options.states
    return int(min(MAX_STATES, max(options.states, round(float(np.median(lengths)) / FRAMES_PER_STATE))))


def _prepare(
    clips: Sequence[tuple[Motion, str]],
    action: str,
    options: Options,
    segmentation: Segmentation,
    template: Template | None = None,
) -> tuple[ActionShape, Template, list[Instance], list[FloatArray], FloatArray, Options]:
    """What both trainings start from: which limbs cycle (measured from the clips, never
    from the action's name), skeleton template, unit instances, static features, the
    variance floor and the options with the states per unit."""
    motions = [m for m, _ in clips]
    shape = action_shape(motions)
    if template is None:
        # Locomotion whose heading changes is aligned to its path frame by frame (turning);
        # standing actions may spin a full turn: the root as swing-twist (prep.twist_features)
        turning = shape.travels and turning_rate(motions) != 0.0
        template = replace(build_template(motions, turning=turning), twisted_root=not shape.travels)
    if segmentation is not None:
        lengths = [s.length for segments in segmentation if segments for s in segments]
    else:
        lengths = [m.frame_count for m, _ in clips]
    options = replace(options, states=unit_states(shape.cyclic, lengths, options))
    instances, statics = gather_instances(clips, template, shape.cycle, options.states, segmentation)
    return shape, template, instances, statics, variance_floor(instances), options


@one_blas_thread
def train_average(
    clips: Sequence[tuple[Motion, str]],
    action: str,
    options: Options = Options(),
    segmentation: Segmentation = None,
) -> HsmmModel:
    """Average model over (motion, style) clips with style-adaptive training."""
    shape, template, instances, statics, floor, options = _prepare(clips, action, options, segmentation)
    cycle = shape.cycle
    blocks = blocks_for(template.feature_count, options.blocks)
    units, _ = adaptive_training(
        instances,
        options.states,
        floor,
        blocks,
        rounds=options.sat_rounds,
        prior=options.prior,
        soft=options.soft_training,
    )
    gv_mean, gv_var = _gv_stats(statics)
    return HsmmModel(
        action=action,
        style="average",
        cycle=cycle,
        units=units,
        template=template,
        gv_mean=gv_mean,
        gv_var=gv_var,
        variance_floor=floor,
        first_leg=_first_leg(instances),
        info={
            "clips": len(clips),
            "styles": sorted({s for _, s in clips}),
            "frames": int(np.median([m.frame_count for m, _ in clips])),
            "period_s": shape.period_s,
            **_turn_info(template, [m for m, _ in clips]),
            **_last_units(instances),
            **asdict(options),
        },
        carried=carried_profiles(units, instances) if cycle == "steps" else {},
    )


def _turn_info(template: Template, motions: Sequence[Motion]) -> dict[str, float]:
    """``{"turn_rate": radians per second}`` of turning locomotion (the clips' median
    :func:`mse.motion.base.heading.turn_rate`; the turn per cycle follows from the data);
    nothing for other actions (their model files stay as they were)."""
    if not template.turning:
        return {}
    return {"turn_rate": float(np.median([turn_rate(m) for m in motions]))}


@one_blas_thread
def train_scratch(
    clips: Sequence[tuple[Motion, str]],
    action: str,
    options: Options = Options(),
    segmentation: Segmentation = None,
    template: Template | None = None,
) -> HsmmModel:
    """A style model trained on its own data only, without an average model (the bench's
    baseline). ``template``: the skeleton template and reference rotations to use (e.g. an
    average model's, so that both models describe the same features); default: its own."""
    shape, template, instances, statics, floor, options = _prepare(clips, action, options, segmentation, template)
    cycle = shape.cycle
    if options.soft_training:
        from mse.motion.hsmm.soft_training import train_units_soft

        units = train_units_soft(instances, options.states, options.iterations, floor)
    else:
        units, _ = train_units(instances, options.states, options.iterations, floor)
    gv_mean, gv_var = _gv_stats(statics)
    return HsmmModel(
        action,
        clips[0][1],
        cycle,
        units,
        template,
        gv_mean,
        gv_var,
        floor,
        _first_leg(instances),
        info={
            "takes": len(clips),
            "trained_on": "style data only",
            "frames": int(np.median([m.frame_count for m, _ in clips])),
            "period_s": shape.period_s,
            **_turn_info(template, [m for m, _ in clips]),
            **_last_units(instances),
            **asdict(options),
        },
        carried=carried_profiles(units, instances) if cycle == "steps" else {},
    )


@one_blas_thread
def adapt_model(
    average: HsmmModel,
    motions: Sequence[Motion],
    style: str,
    options: Options = Options(),
    segmentation: Segmentation = None,
) -> HsmmModel:
    """The average model adapted to ``style`` from a few clips (CMLLR then MAP).

    ``segmentation``: labelled unit segments per motion (e.g. a few steps of a take, with
    the contexts they have in the take); default: each motion is a complete sequence.
    """
    template = average.template
    instances, statics = gather_instances(
        [(m, style) for m in motions], template, average.cycle, average.states, segmentation
    )
    # A style starts with the leg its takes start with: a walk started on the average model's
    # leg swayed the pelvis in the opposite phase, and its first frame (which measures side
    # travel) faced the wrong way (Bandai dataset 1 walk-left proud starts on leg b, the
    # average on a: side speed 8.1 cm/s, its take 11.7)
    starts = [i for i in instances if i.unit.startswith("first-")]
    first_leg = _first_leg(starts) if starts and average.cyclic else average.first_leg
    instances = [replace(i, unit=average.resolve(i.unit)) for i in instances]
    kind = options.adapt_blocks
    if kind == "auto":
        frames = sum(i.observations.shape[0] for i in instances)
        kind = auto_blocks(template.feature_count, frames)
    own_root = options.root_block and average.travels
    root = 3 * template.rotated.index(template.root_joint) if own_root else None
    blocks = blocks_for(template.feature_count, kind, root)
    units, _output, _ = adapt_units(
        average.units,
        instances,
        average.variance_floor,
        blocks,
        prior=options.prior,
        tau=options.tau,
        tau_duration=options.tau_duration,
        use_map=options.use_map,
        soft=options.soft,
        regression_classes=options.regression_classes,
        unit_classes=options.unit_classes,
        by_context=options.context_classes and average.cycle == "hands",
    )
    target = np.array([global_variance(s) for s in statics])
    gv_mean = (options.gv_tau * average.gv_mean + target.sum(axis=0)) / (
        options.gv_tau + target.shape[0]
    )
    if options.style_gv_spread:
        # The average model's GV spread is mostly BETWEEN styles; one style varies less.
        # Same rule as a model trained on the target data alone (_gv_stats).
        gv_var = np.maximum(target.var(axis=0), (0.1 * gv_mean) ** 2 + 1e-12)
    else:
        gv_var = average.gv_var * (gv_mean / np.maximum(average.gv_mean, 1e-12)) ** 2
    return replace(
        average,
        style=style,
        units=units,
        first_leg=first_leg,
        gv_mean=gv_mean,
        gv_var=gv_var,
        info={
            **dict(average.info),
            "adapted_from": average.style,
            "takes": len(motions),
            "frames": int(np.median([m.frame_count for m in motions])),
            "adapt_blocks": kind,
            **_turn_info(template, motions),  # the style's own turn
            **_last_units(instances),  # the style's own ends
        },
        carried=carried_profiles(units, instances, prior=average.carried) if average.carried else {},
    )

"""Style adaptation: constrained MLLR then MAP (paper §5.1.3, eq. 5–6), and adaptive training.

CMLLR (Gales 1998) estimates one affine transform per style, shared by the means and the
variances.  It is estimated in feature space, ``x̂ = A x + b``, row by row (closed form up to
a quadratic in the cofactor scale), and applied to the model as ``μ̂ = A⁻¹(μ - b)``,
``Σ̂ = A⁻¹ Σ A⁻ᵀ``; only the diagonal of ``Σ̂`` is kept so that generation stays banded.
``A`` is block diagonal ("regression blocks"): one block per stream (static, Δ, Δ², HTS's
usual choice), ``joint`` (3×3 per joint and stream, the most robust to tiny data) or
``full``; adaptation picks stream or joint blocks by the amount of data (:func:`auto_blocks`).
A Gaussian prior centred on the identity (weight ``prior``) keeps rows with little data near
identity; per-leg regression classes then get their own transforms with the global one as
prior centre (the structural-MAP idea of CSMAPLR); waves' classes are their contexts, the
rise and the fall with per-joint refinements and tempos of their own (:func:`adapt_units`).
The transforms and their estimation are in :mod:`mse.motion.hsmm.cmllr`.  Durations get a
transform that cannot collapse (:func:`estimate_duration_scale`): a diagonal one, each state's scale shrunk towards
the global tempo of the data and kept within a factor :data:`DURATION_SCALE_RANGE` of it (a
full 5×5 CMLLR estimated from one bow take had turned the state durations into
[63, 1, 1, 1, 24] frames, and the adapted bows barely bowed); MAP then keeps every state at
least :data:`DURATION_FLOOR` of its transformed mean.

Statistics are occupancy-weighted (forward-backward over each unit's state runs,
:mod:`mse.motion.hsmm.occupancy`) as in HTS; ``soft=False`` uses one Viterbi alignment.
MAP then moves every Gaussian that has data towards it (``τ`` = prior weight in frames; by
default one visit of the state, i.e. its mean duration, so a state seen once in the
adaptation data ends half-way between prior and data).  Adaptive training (SAT, the
paper's walker-adaptive training) alternates per-style transforms with re-estimation of
the average model on the transformed data.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from mse import progress
from mse.motion.hsmm.cmllr import (
    FRAMES_PER_PARAMETER,
    AffineTransform,
    auto_blocks,
    blocks_for,
    estimate_cmllr,
    estimate_refinement,
)
from mse.motion.hsmm.features import FloatArray
from mse.motion.hsmm.model import (
    DURATION_VARIANCE_FLOOR,
    Instance,
    UnitModel,
    estimate_units,
    realign,
    train_units,
)
from mse.motion.hsmm.stats import GaussianStats, collect_stats, duration_stats, output_stats

__all__ = [
    "AffineTransform",
    "GaussianStats",
    "adapt_units",
    "adaptive_training",
    "auto_blocks",
    "blocks_for",
    "class_blocks",
    "estimate_cmllr",
    "estimate_duration_scale",
    "map_update",
    "regression_class",
    "transform_units",
]


#: a state's duration scale stays within this factor of the global tempo
DURATION_SCALE_RANGE = 2.0
#: MAP keeps a state's mean duration at least this share of its prior (transformed) mean
DURATION_FLOOR = 0.5


def estimate_duration_scale(stats: Sequence[GaussianStats], prior: float = 1.0) -> AffineTransform:
    """A diagonal feature-space duration transform (``x̂ = A x``, ``A = diag(1 / a_s)``).

    The global tempo ``a`` is the ratio of the observed frames to the frames the model
    expects for the same unit instances; each state's scale ``a_s`` is the MAP estimate with
    a prior of ``prior`` instances at ``a``, clipped to ``[a / r, a r]`` with
    ``r`` = :data:`DURATION_SCALE_RANGE`.  No state can shrink to nothing.
    """
    states = stats[0].mean.shape[0]
    counts = np.array([s.count for s in stats])
    if counts.sum() <= 0:
        return AffineTransform.identity(states)
    observed = np.sum([s.total for s in stats], axis=0)  # (S,) frames per state
    expected = np.sum([s.count * s.mean for s in stats], axis=0)  # (S,)
    tempo = float(observed.sum() / max(expected.sum(), 1e-9))
    per_instance = expected / counts.sum()
    scales = (observed + prior * tempo * per_instance) / (expected + prior * per_instance)
    scales = np.clip(scales, tempo / DURATION_SCALE_RANGE, tempo * DURATION_SCALE_RANGE)
    return AffineTransform(np.diag(1.0 / scales), np.zeros(states))


def regression_class(unit: str, by_context: bool = False, timing: bool = False) -> str:
    """The regression class of a unit: its swing leg (``a``/``b``) for steps, else itself.

    Steps of the same leg (first/inner/last) share most of their poses, so a transform
    estimated on the steps seen in the adaptation data carries over to unseen contexts.
    ``by_context`` (hand cycles, i.e. waves): the context (``first``/``inner``/``last``)
    instead, because a wave's first and last units raise and lower the arms, poses that
    its swings of either side never take. A wave's ``second`` unit (the return from the
    rise's last turn) swings through the swings' poses, so its output transform is the
    ``inner`` class's; with ``timing`` (duration transforms) it is a class of its own: its
    tempo is not the swings' (Bandai dataset 2 feminine: 9-11 frames, its holds 5-166).
    """
    context, _, leg = unit.partition("-")
    if not by_context:
        return leg or context
    return "inner" if context == "second" and not timing else context


def class_blocks(
    blocks: Sequence[np.ndarray], static_dims: int, frames: float, small: bool = False
) -> tuple[Sequence[np.ndarray], float]:
    """The blocks of a regression class's transform and its prior weight (frames).

    The adaptation's blocks when the class holds :data:`FRAMES_PER_PARAMETER` frames per row
    parameter of them; the prior weight is that threshold, so a class at it lands half-way
    between its parent and its data. Else, with ``small`` (a wave's rise and fall, see
    :func:`adapt_units`), per-joint 3×3 blocks when the class holds that many frames for
    those (8), as :func:`auto_blocks` falls back to them; else no transform (empty).
    """
    needed = FRAMES_PER_PARAMETER * (max(len(b) for b in blocks) + 1.0)
    if frames >= needed:
        return blocks, needed
    joint_needed = FRAMES_PER_PARAMETER * (3 + 1.0)
    if small and frames >= joint_needed and needed > joint_needed:
        return blocks_for(static_dims, "joint"), joint_needed
    return [], needed


def transform_units(
    units: Mapping[str, UnitModel],
    output: AffineTransform,
    duration: AffineTransform,
    classes: Mapping[str, AffineTransform] | None = None,
    by_context: bool = False,
    duration_classes: Mapping[str, AffineTransform] | None = None,
) -> dict[str, UnitModel]:
    """The model seen through feature-space transforms (eq. 5–6, diagonal variances);
    ``classes`` overrides ``output`` for the units of a regression class
    (:func:`regression_class` with ``by_context``)."""
    out = {}
    for name, unit in units.items():
        # The most specific class that has a transform: the unit's own, then its leg's.
        found = classes or {}
        transform = found.get(f"unit:{name}", found.get(regression_class(name, by_context), output))
        means, variances = transform.model_space(unit.means, unit.variances)
        timing = (duration_classes or {}).get(regression_class(name, by_context, timing=True), duration)
        d_means, d_vars = timing.model_space(
            unit.duration_means[None, :], unit.duration_variances[None, :]
        )
        out[name] = UnitModel(
            means,
            variances,
            np.maximum(d_means[0], 1.0),
            np.maximum(d_vars[0], DURATION_VARIANCE_FLOOR),
        )
    return out


def map_update(
    units: Mapping[str, UnitModel],
    instances: Sequence[Instance],
    floor: FloatArray,
    tau: float | None = None,
    tau_duration: float = 1.0,
    soft: bool = True,
) -> dict[str, UnitModel]:
    """MAP re-estimation with the given units as priors (no data: unchanged).

    ``tau`` (frames) None: each state's prior is worth one visit, its mean duration.
    ``tau_duration`` is in unit instances.
    """
    out = dict(units)
    stats, dstats = collect_stats(instances, units, units, soft)
    for name, unit in units.items():
        means, variances = unit.means.copy(), unit.variances.copy()
        for s in range(unit.states):
            st = stats.get((name, s))
            if st is None:
                continue
            weight = float(unit.duration_means[s]) if tau is None else tau
            squares = np.diag(st.scatter)
            means[s] = (weight * unit.means[s] + st.total) / (weight + st.count)
            second = (weight * (unit.variances[s] + unit.means[s] ** 2) + squares) / (
                weight + st.count
            )
            variances[s] = np.maximum(second - means[s] ** 2, floor)
        d_means, d_vars = unit.duration_means.copy(), unit.duration_variances.copy()
        ds = dstats.get(name)
        if ds is not None:
            d_means = (tau_duration * unit.duration_means + ds.total) / (tau_duration + ds.count)
            second = (
                tau_duration * (unit.duration_variances + unit.duration_means**2)
                + np.diag(ds.scatter)
            ) / (tau_duration + ds.count)
            d_vars = np.maximum(second - d_means**2, DURATION_VARIANCE_FLOOR)
            d_means = np.maximum(d_means, DURATION_FLOOR * unit.duration_means)
        out[name] = UnitModel(means, variances, np.maximum(d_means, 1.0), d_vars)
    return out


def adapt_units(
    units: Mapping[str, UnitModel],
    instances: Sequence[Instance],
    floor: FloatArray,
    blocks: Sequence[np.ndarray],
    prior: float = 1.0,
    passes: int = 2,
    tau: float | None = None,
    tau_duration: float = 1.0,
    use_map: bool = True,
    soft: bool = True,
    regression_classes: bool = True,
    unit_classes: bool = False,
    by_context: bool = False,
) -> tuple[dict[str, UnitModel], AffineTransform, AffineTransform]:
    """CMLLR (output and duration) then MAP on the target instances.

    With ``regression_classes``, a two-level tree: the global transform, then one per
    regression class (:func:`regression_class`) that holds at least two frames per row
    parameter, estimated with the global transform as its prior centre (weight: that
    same number of frames, so a class at the threshold lands half-way).

    ``by_context`` (hand cycles): the classes are the contexts; a class too small for the
    adaptation's blocks gets per-joint blocks (:func:`class_blocks`) on top of the global
    transform (:func:`estimate_refinement`), and each class gets its own duration transform
    (its own tempo). A wave's rise and fall are one unit each (10-25 frames of a take): the
    swings' frames dominated the global transforms, and the Bandai dataset 2 feminine wave,
    whose swings are 1-2 cm ripples held for 83 and 94 frames, was adapted to raise its hands
    in 37 frames (its take: 13) from half-way up, 6 cm outward where the take's go 18 cm.
    """
    states = next(iter(units.values())).states
    output = AffineTransform.identity(floor.shape[0])
    duration = AffineTransform.identity(states)
    adapted = dict(units)
    for _ in range(passes):
        # Posteriors under the current adapted model; statistics against the *source*
        # model's Gaussians, which the transforms map onto the data.
        stats, dstats = collect_stats(instances, units, adapted, soft)
        output = estimate_cmllr(list(stats.values()), blocks, prior)
        duration = estimate_duration_scale(list(dstats.values()), prior)
        classes: dict[str, AffineTransform] = {}
        groups: dict[str, list[GaussianStats]] = {}
        for (name, _state), st in stats.items():
            groups.setdefault(regression_class(name, by_context), []).append(st)
        needed = FRAMES_PER_PARAMETER * (max(len(b) for b in blocks) + 1.0)
        for label, members in groups.items() if regression_classes and len(groups) > 1 else ():
            frames = sum(m.count for m in members)
            own, weight = class_blocks(blocks, floor.shape[0] // 3, frames, small=by_context)
            if own and frames >= weight:
                if own is blocks:
                    classes[label] = estimate_cmllr(members, own, weight, centre=output)
                else:
                    classes[label] = estimate_refinement(members, own, weight, output)
        if unit_classes:
            # Third level of the tree: a unit with enough frames gets its own transform,
            # centred on its leg's (or the global) transform.
            by_unit: dict[str, list[GaussianStats]] = {}
            for (name, _state), st in stats.items():
                by_unit.setdefault(name, []).append(st)
            for name, members in by_unit.items():
                parent = classes.get(regression_class(name, by_context), output)
                if sum(m.count for m in members) >= needed and len(by_unit) > 1:
                    classes[f"unit:{name}"] = estimate_cmllr(members, blocks, needed, centre=parent)
        timing: dict[str, AffineTransform] = {}
        if by_context:
            # Each context its own tempo (see the docstring).
            by_class: dict[str, list[GaussianStats]] = {}
            for name, st in dstats.items():
                by_class.setdefault(regression_class(name, by_context, timing=True), []).append(st)
            timing = {label: estimate_duration_scale(members, prior) for label, members in by_class.items()}
        adapted = transform_units(units, output, duration, classes, by_context, timing)
    if use_map:
        adapted = map_update(adapted, instances, floor, tau, tau_duration, soft)
    return adapted, output, duration


def adaptive_training(
    instances: Sequence[Instance],
    states: int,
    floor: FloatArray,
    blocks: Sequence[np.ndarray],
    rounds: int = 2,
    prior: float = 1.0,
    soft: bool = False,
) -> tuple[dict[str, UnitModel], dict[str, tuple[AffineTransform, AffineTransform]]]:
    """Average model by style-adaptive training: per-style transforms + re-estimation.

    ``soft``: transforms and re-estimation from occupancy-weighted statistics (HTS), after
    the segmental-k-means start; else from Viterbi alignments.
    """
    with progress.bar(1 + rounds, "train", unit="round") as steps:
        return _adaptive_training(instances, states, floor, blocks, rounds, prior, soft, steps)


def _adaptive_training(
    instances: Sequence[Instance],
    states: int,
    floor: FloatArray,
    blocks: Sequence[np.ndarray],
    rounds: int,
    prior: float,
    soft: bool,
    steps: progress.Bar,
) -> tuple[dict[str, UnitModel], dict[str, tuple[AffineTransform, AffineTransform]]]:
    units, aligned = train_units(instances, states, floor=floor)
    steps.update()
    transforms: dict[str, tuple[AffineTransform, AffineTransform]] = {}
    styles = sorted({i.style for i in instances})
    if soft:
        from mse.motion.hsmm.soft_training import estimate_units_soft

        units = estimate_units_soft(aligned, units, floor)
        for _ in range(rounds):
            for style in styles:
                stats, dstats = collect_stats([i for i in aligned if i.style == style], units, units, True)
                transforms[style] = (
                    estimate_cmllr(list(stats.values()), blocks, prior),
                    estimate_duration_scale(list(dstats.values()), prior),
                )
            units = estimate_units_soft(
                aligned,
                units,
                floor,
                transform=lambda style, o: transforms[style][0].apply(o),
                duration_transform=lambda style, d: transforms[style][1].apply(d),
            )
            steps.update()
        return units, transforms
    for _ in range(rounds):
        for style in styles:
            mine = [i for i in aligned if i.style == style]
            output = estimate_cmllr(list(output_stats(mine, units).values()), blocks, prior)
            duration = estimate_duration_scale(list(duration_stats(mine, units).values()), prior)
            transforms[style] = (output, duration)
        normalised = [
            Instance(i.unit, i.style, transforms[i.style][0].apply(i.observations), i.bounds)
            for i in aligned
        ]
        units = estimate_units(
            normalised,
            states,
            floor,
            duration_transform=lambda style, d: transforms[style][1].apply(d),
        )
        aligned = [
            Instance(i.unit, i.style, i.observations, n.bounds)
            for i, n in zip(aligned, realign(normalised, units), strict=True)
        ]
        steps.update()
    return units, transforms

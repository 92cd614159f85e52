"""Left-to-right HSMM units with explicit state durations (paper §5.1.1, Fig. 3).

A unit (a step in context, or a whole one-shot action) has ``S`` emitting states (5 by
default) in a left-to-right chain without skips.  Each state has one diagonal Gaussian over
the observation ``[c, Δc, Δ²c]`` and one Gaussian over its duration in frames.

Training is Viterbi (segmental k-means) EM: unit boundaries come from the step
segmentation, states start as equal splits, then alternate between re-estimating the
Gaussians from the frames each state holds and re-aligning every unit instance with the
HSMM Viterbi search (``align``: the best split of ``L`` frames into ``S`` consecutive
non-empty runs, scored by output and duration log densities).  hmmlearn has no explicit-
duration left-to-right model, so this is plain numpy.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from mse.motion.base.cycles import CycleKind
from mse.motion.hsmm.features import FloatArray
from mse.motion.hsmm.prep import Template

LOG_2PI = float(np.log(2.0 * np.pi))
#: HTS's variance floor: this fraction of the global variance of each dimension.
VARIANCE_FLOOR_RATIO = 0.01
DURATION_VARIANCE_FLOOR = 1.0  # frames²


@dataclass(frozen=True, eq=False)
class UnitModel:
    """One left-to-right unit: per-state output and duration Gaussians."""

    means: FloatArray  # (S, 3D)
    variances: FloatArray  # (S, 3D)
    duration_means: FloatArray  # (S,) frames
    duration_variances: FloatArray  # (S,) frames²

    @property
    def states(self) -> int:
        return int(self.means.shape[0])


@dataclass(frozen=True, eq=False)
class HsmmModel:
    """A trained (average or adapted) model of one action."""

    action: str
    style: str
    #: which limbs carry the action's cycle, measured from its clips
    #: (:func:`mse.motion.base.cycles.action_shape`; "steps": the action travels)
    cycle: CycleKind
    units: Mapping[str, UnitModel]
    template: Template
    gv_mean: FloatArray  # (D,) global variance of the statics, per dimension
    gv_var: FloatArray  # (D,)
    variance_floor: FloatArray  # (3D,)
    first_leg: str = "a"
    info: Mapping[str, object] = field(default_factory=dict)
    #: per unit, (S, 4) how each state carries the body: root velocity along X and Z in the
    #: aligned frame, foot lift, support (flight phases of runs; empty: feet always pinned)
    carried: Mapping[str, FloatArray] = field(default_factory=dict)

    @property
    def cyclic(self) -> bool:
        return self.cycle != "none"

    @property
    def travels(self) -> bool:
        return self.cycle == "steps"

    @property
    def states(self) -> int:
        return next(iter(self.units.values())).states

    def resolve(self, name: str) -> str:
        """``name`` if trained, else the closest trained unit (same context, then same leg)."""
        if name in self.units:
            return name
        context, _, leg = name.partition("-")
        for candidate in (f"{context}-{'b' if leg == 'a' else 'a'}", f"inner-{leg}", "inner-a"):
            if candidate in self.units:
                return candidate
        return next(iter(self.units))

    def unit(self, name: str) -> UnitModel:
        return self.units[self.resolve(name)]


@dataclass(frozen=True, eq=False)
class Instance:
    """One unit occurrence in a training clip, with its current state boundaries."""

    unit: str
    style: str
    observations: FloatArray  # (L, 3D)
    bounds: tuple[int, ...]  # S + 1 increasing frame indices, 0 .. L
    #: (L, 4) how the body is carried in these frames (see :mod:`mse.motion.hsmm.carried`)
    carried: FloatArray | None = None

    def durations(self) -> FloatArray:
        return np.diff(np.asarray(self.bounds, dtype=np.float64))


# -- likelihoods and alignment ------------------------------------------------------------
def frame_loglik(observations: FloatArray, means: FloatArray, variances: FloatArray) -> FloatArray:
    """(L, S) log density of every frame under every state's diagonal Gaussian."""
    precision = 1.0 / variances
    quadratic = (
        (observations**2) @ precision.T
        - 2.0 * observations @ (means * precision).T
        + np.sum(means**2 * precision, axis=1)[None, :]
    )
    constant = np.sum(np.log(variances), axis=1) + means.shape[1] * LOG_2PI
    result: FloatArray = -0.5 * (quadratic + constant[None, :])
    return result


def duration_logpdf(lengths: FloatArray, mean: float, variance: float) -> FloatArray:
    result: FloatArray = -0.5 * ((lengths - mean) ** 2 / variance + np.log(variance) + LOG_2PI)
    return result


def uniform_bounds(length: int, states: int) -> tuple[int, ...]:
    return tuple(round(b) for b in np.linspace(0, length, states + 1))


#: a state's run lasts at most this many times the unit instance's frames per state (HTS
#: bounds state durations too). It keeps the lattice of a long one-shot clip with many states
#: at O(S·L·R) instead of O(S·L²): the 63 s Bandai dance at 60 states needed 1.7 GB for its
#: run scores, which capped the states per unit. At 64, every other Bandai action keeps its
#: whole lattice (a 46-state bye: 258 frames allowed, the take has 185); at 16, runs of
#: held poses were cut and the bye and byebye alignments changed (jerk up to 1.9x).
RUN_SPAN = 64


def max_run(length: int, states: int) -> int:
    """The longest run a state may have in an instance of ``length`` frames."""
    return int(min(length, max(1, np.ceil(RUN_SPAN * length / max(states, 1)))))


def _run_parts(
    cumulative: FloatArray, unit: UnitModel, state: int, longest: int
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Output log density (L+1, R) of the run of ``state`` over ``[b, b + r + 1)`` for every
    start ``b`` and length ``r + 1`` up to ``longest``, the duration log densities (R,) and
    where the run fits in the instance (L+1, R)."""
    length = cumulative.shape[0] - 1
    lengths = np.arange(1, longest + 1)
    begin = np.arange(length + 1)[:, None]
    end = begin + lengths[None, :]
    column = cumulative[:, state]
    output = column[np.minimum(end, length)] - column[begin]
    duration = duration_logpdf(
        lengths.astype(np.float64), float(unit.duration_means[state]), float(unit.duration_variances[state])
    )
    return output, duration, end <= length


def run_scores(cumulative: FloatArray, unit: UnitModel, state: int, longest: int) -> FloatArray:
    """(L+1, R) log density of the run of ``state`` over frames ``[b, b + r + 1)`` (output
    and duration), for every start ``b`` and length ``r + 1`` up to ``longest``; -inf past
    the instance's end. ``cumulative``: (L+1, S) cumulative frame log densities."""
    output, duration, inside = _run_parts(cumulative, unit, state, longest)
    result: FloatArray = np.where(inside, output + duration[None, :], -np.inf)
    return result


def align(loglik: FloatArray, unit: UnitModel) -> tuple[tuple[int, ...], float]:
    """HSMM Viterbi: the best split of the frames into the unit's states, and its score
    (runs of at most :func:`max_run` frames)."""
    length, states = loglik.shape
    if length < states:
        return uniform_bounds(length, states), float("-inf")
    cumulative = np.vstack([np.zeros((1, states)), np.cumsum(loglik, axis=0)])
    longest = max_run(length, states)
    # Runs ending at e start at e - r; scanning r from the longest keeps ties on the
    # earliest start, as a search over starts in order would.
    lengths = np.arange(longest, 0, -1)
    ends = np.arange(length + 1)[:, None]
    starts = ends - lengths[None, :]  # (L+1, R)
    possible = starts >= 0
    safe = np.maximum(starts, 0)
    columns = (lengths - 1)[None, :]  # each length's column in _run_parts
    best = np.full(length + 1, -np.inf)
    best[0] = 0.0
    back = np.zeros((states, length + 1), dtype=np.int64)
    for s in range(states):
        output, duration, _ = _run_parts(cumulative, unit, s, longest)  # by start and length
        score = np.where(possible, best[safe] + output[safe, columns] + duration[columns], -np.inf)
        pick = np.argmax(score, axis=1)
        back[s] = safe[np.arange(length + 1), pick]
        best = score[np.arange(length + 1), pick]
    bounds = [length]
    for s in range(states - 1, -1, -1):
        bounds.append(int(back[s, bounds[-1]]))
    return tuple(reversed(bounds)), float(best[length])


# -- estimation ---------------------------------------------------------------------------
Transform = Callable[[str, FloatArray], FloatArray]  # (style, observations) -> observations


def identity_transform(_style: str, observations: FloatArray) -> FloatArray:
    return observations


def variance_floor(instances: Sequence[Instance]) -> FloatArray:
    frames = np.concatenate([i.observations for i in instances])
    result: FloatArray = np.maximum(VARIANCE_FLOOR_RATIO * np.var(frames, axis=0), 1e-10)
    return result


def estimate_units(
    instances: Sequence[Instance],
    states: int,
    floor: FloatArray,
    transform: Transform = identity_transform,
    duration_transform: Transform = identity_transform,
) -> dict[str, UnitModel]:
    """Maximum-likelihood Gaussians from the frames and durations each state holds."""
    by_unit: dict[str, list[Instance]] = {}
    for instance in instances:
        by_unit.setdefault(instance.unit, []).append(instance)
    units: dict[str, UnitModel] = {}
    for name, members in sorted(by_unit.items()):
        width = members[0].observations.shape[1]
        sums = np.zeros((states, width))
        squares = np.zeros((states, width))
        counts = np.zeros(states)
        durations = []
        for member in members:
            obs = transform(member.style, member.observations)
            for s in range(states):
                chunk = obs[member.bounds[s] : member.bounds[s + 1]]
                sums[s] += chunk.sum(axis=0)
                squares[s] += (chunk**2).sum(axis=0)
                counts[s] += chunk.shape[0]
            durations.append(duration_transform(member.style, member.durations()[None, :])[0])
        safe = np.maximum(counts, 1.0)[:, None]
        means = sums / safe
        variances = np.maximum(squares / safe - means**2, floor[None, :])
        stacked = np.asarray(durations)
        units[name] = UnitModel(
            means=means,
            variances=variances,
            duration_means=np.maximum(stacked.mean(axis=0), 1.0),
            duration_variances=np.maximum(stacked.var(axis=0), DURATION_VARIANCE_FLOOR),
        )
    return units


def realign(
    instances: Sequence[Instance],
    units: Mapping[str, UnitModel],
    transform: Transform = identity_transform,
) -> list[Instance]:
    """Every instance re-split into states by the HSMM Viterbi search."""
    out = []
    for instance in instances:
        unit = units[instance.unit]
        obs = transform(instance.style, instance.observations)
        bounds, score = align(frame_loglik(obs, unit.means, unit.variances), unit)
        if score == float("-inf"):
            bounds = instance.bounds
        out.append(Instance(instance.unit, instance.style, instance.observations, bounds))
    return out


def train_units(
    instances: Sequence[Instance],
    states: int,
    iterations: int = 4,
    floor: FloatArray | None = None,
) -> tuple[dict[str, UnitModel], list[Instance]]:
    """Segmental k-means from equal splits; returns the units and the final alignment."""
    floor = variance_floor(instances) if floor is None else floor
    current = list(instances)
    units = estimate_units(current, states, floor)
    for _ in range(iterations):
        current = realign(current, units)
        units = estimate_units(current, states, floor)
    return units, current


def total_loglik(instances: Sequence[Instance], units: Mapping[str, UnitModel]) -> float:
    """Sum of the aligned output and duration log densities (a training monitor)."""
    total = 0.0
    for instance in instances:
        unit = units[instance.unit]
        loglik = frame_loglik(instance.observations, unit.means, unit.variances)
        for s in range(unit.states):
            total += float(loglik[instance.bounds[s] : instance.bounds[s + 1], s].sum())
            total += float(
                duration_logpdf(
                    np.array(instance.durations()[s]),
                    float(unit.duration_means[s]),
                    float(unit.duration_variances[s]),
                )
            )
    return total

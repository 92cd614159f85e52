"""Objectives of the CP-SAT backend: the profile's perturb-and-MAP by default, others on request.

Perturb-and-MAP (Papandreou & Yuille 2011): the maximum of a model's log-probabilities plus
independent Gumbel noise on every choice is a sample of the model.  Each decided slot
chooses one option of its :class:`~mse.solve.cpsat.prior.SlotPrior` (absent, a start bin,
or "later"), scored by its prior log-probability plus Gumbel noise.  The noise is drawn
*conditioned on the drawn option being the best* (top-down Gumbel sampling, Maddison et al.
2014): the unconstrained maximum is then exactly the prior draw, whose law is the profile's,
and constraints that rule the draw out make the search trade the remaining options by their
perturbed scores.  Scores are shifted so that the drawn option scores 0 and every other
option less: a consistent draw is optimal at once (objective 0, the trivial bound).

Within a bin a slot aims at a target start (the drawn start in the drawn bin, a seeded draw
in the others) and at its drawn length; each millisecond away costs START_WEIGHT or
LENGTH_WEIGHT units, so positions and lengths follow the profile too instead of sliding to
the edges of the bins.  A signal whose probabilities are both 0 costs more than every other
term together (:func:`set_objective`): it occurs only when no consistent timeline exists
without it.  ``likely`` drops the noise (the MAP timeline), ``random`` drops the
probabilities.  Coefficients are SCALE units per nat, rounded to integers.
"""

from __future__ import annotations

import math
import random
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from mse.ir import model as ir
from mse.ir.evaluate import constraint_status
from mse.ir.schedule import Schedule
from mse.solve.bounds import length_bounds
from mse.solve.cpsat.encode import Encoding, Slot, var
from mse.solve.cpsat.prior import ABSENT, IMPOSSIBLE, SlotPrior, expected_starts, window_bins

SCALE = 2000
#: Units per millisecond away from the target start / length (0.5 nat per second).
START_WEIGHT = 1
LENGTH_WEIGHT = 1
#: Weight of one slot's difference (presence, or D ticks of start) for --diverse, in nats.
DIVERSITY_WEIGHT = 3


def gumbel(rng: random.Random) -> float:
    u = min(1.0 - 1e-12, max(1e-12, rng.random()))
    return -math.log(-math.log(u))


def _logsumexp(values: Sequence[float]) -> float:
    top = max(values)
    return top + math.log(sum(math.exp(v - top) for v in values))


def perturbed_scores(prior: SlotPrior, rng: random.Random, mode: str) -> list[float]:
    """Scores of the options [absent, bin 0.., later?] whose maximum is ``prior.choice``."""
    phi = [prior.log_absent, *prior.log_bins] + ([] if prior.log_later is None else [prior.log_later])
    if mode == "likely":
        return phi
    if mode == "random":
        phi = [0.0] * len(phi)
    drawn = prior.choice + 1  # ABSENT (-1) -> 0
    top = _logsumexp(phi) + gumbel(rng)
    scores = []
    for index, value in enumerate(phi):
        if index == drawn:
            scores.append(top)
            continue
        # A Gumbel of location ``value`` truncated below ``top``.
        g = value + gumbel(rng)
        scores.append(-math.log(math.exp(-top) + math.exp(-g)) if g - top < 700 else top - 1e-9)
    return scores


@dataclass(frozen=True)
class _Position:
    """One slot's stage-2 terms before they are encoded: its start should be near
    ``target`` (a linear expression of the bin literals; not when ``later`` holds) and its
    length near ``length``."""

    start: Any
    length: Any
    present: Any
    target: Any
    later: Any
    length_target: int
    duration: int


@dataclass
class Stages:
    """A lexicographic objective: first the options (presence and start bins, the
    perturb-and-MAP part), then, with every option fixed, the positions (distance to the
    target starts and lengths).  ``options`` are the literals whose values stage 2 keeps.

    The positions' distance variables and constraints are added to the model only when
    stage 2 runs (:meth:`second`): in stage 1 they take no part in the objective, but their
    long linear constraints would enter the LP relaxation and its cuts (most of stage 1's
    time, docs/solvers.md "Sampling at 10 s")."""

    first: list[Any] = field(default_factory=list)
    options: list[Any] = field(default_factory=list)
    positions: list[_Position] = field(default_factory=list)
    _second: list[Any] | None = None

    def second(self, cp: Any) -> list[Any]:
        """The stage-2 terms (distance variables added to ``cp`` on the first call)."""
        if self._second is None:
            self._second = []
            for position in self.positions:
                self._second += _distance_terms(cp, position)
        return self._second

    def position_cost(self, solver: Any) -> int:
        """How far a solution's positions are from their targets (the negated stage-2 value)."""
        cost = 0
        for position in self.positions:
            if solver.boolean_value(position.present):
                if position.later is None or not solver.boolean_value(position.later):
                    cost += START_WEIGHT * abs(solver.value(position.start) - solver.value(position.target))
                cost += LENGTH_WEIGHT * abs(solver.value(position.length) - position.length_target)
            else:
                cost += LENGTH_WEIGHT * solver.value(position.length)
        return cost


def _distance_terms(cp: Any, position: _Position) -> list[Any]:
    start_distance = cp.new_int_var(0, position.duration, "")
    away = [cp.add(start_distance >= position.start - position.target),
            cp.add(start_distance >= position.target - position.start)]
    if position.later is not None:
        for constraint in away:
            constraint.only_enforce_if(~position.later)
    length_distance = cp.new_int_var(0, position.duration, "")
    present_length = position.length_target * position.present
    cp.add(length_distance >= position.length - present_length)
    cp.add(length_distance >= present_length - position.length)
    return [-START_WEIGHT * start_distance, -LENGTH_WEIGHT * length_distance]


def _choice_terms(enc: Encoding, slot: Slot, prior: SlotPrior, scores: Sequence[float],
                  stages: Stages) -> int:
    """Add one slot's terms to ``stages``: its option scores (drawn option 0, others < 0)
    and its distances to the target start and length.  Returns how low its option terms
    can go (negated).

    Options are one-hot: one literal per bin ("present and starting in bin b") and one for
    "later", which sum to ``present``; each costs its own non-positive score.  (An order
    encoding, "start >= edge b", telescopes the scores into coefficients of both signs, so
    that the objective bound alone prunes nothing and CP-SAT has to prove the optimum with
    the LP at every node: 2-3x slower, docs/solvers.md "Sampling at 10 s".)  The first bin
    has no lower edge and the last one, without "later", no upper edge: an absent slot
    starts at 0, where no bin literal holds."""
    cp = enc.cp
    start, length, present = var(slot.start), var(slot.length), slot.present
    best = scores[prior.choice + 1]
    units = [min(0, round(SCALE * (score - best))) for score in scores]
    terms = stages.first
    if units[0]:
        terms.append(units[0] * (1 - present))
    stages.options.append(present)
    last = len(prior.bins) - 1
    # Bins where the slot cannot start get no literal: after the last start where the
    # shortest occurrence fits, and, for the k-th slot of a repetitive signal, before k
    # shortest occurrences since the frame's beginning (the slots are chained).
    signal = enc.model.signal(slot.signal)
    low, _ = length_bounds(signal, enc.duration)
    latest = enc.duration - low
    earliest = enc.frame.begin + (prior.index * low if signal.repetitive else 0)
    literals: list[Any] = []
    target: list[Any] = []
    for index, (lo, hi) in enumerate(prior.bins):
        if lo > latest or hi - 1 < earliest:
            continue
        literal = cp.new_bool_var("")
        if index > 0:
            cp.add(start >= lo).only_enforce_if(literal)
        if index < last or prior.log_later is not None:
            cp.add(start <= hi - 1).only_enforce_if(literal)
        literals.append(literal)
        if units[index + 1]:
            terms.append(units[index + 1] * literal)
        if prior.targets[index]:
            target.append(prior.targets[index] * literal)
    later_literal = None
    if prior.log_later is not None:
        later_literal = cp.new_bool_var("")
        cp.add(start >= prior.bins[-1][1]).only_enforce_if(later_literal)
        literals.append(later_literal)
        if units[-1]:
            terms.append(units[-1] * later_literal)
    cp.add(sum(literals) == present)
    stages.options.extend(literals)
    stages.positions.append(_Position(start, length, present, sum(target), later_literal, prior.length,
                                      enc.duration))
    return -min(units)


def hint(enc: Encoding, slot: Slot, start: int, length: int) -> None:
    """Hint ``slot`` present at [start, start + length) (absent when start < 0)."""
    if start < 0 or start + length > enc.duration or length < 1:
        enc.cp.add_hint(slot.present, False)
        return
    enc.cp.add_hint(slot.present, True)
    enc.cp.add_hint(slot.start, start)
    enc.cp.add_hint(slot.length, length)
    enc.cp.add_hint(slot.stop, start + length)


def required_signals(model: ir.Model, require: Sequence[str] = ()) -> frozenset[str]:
    """Signals that must occur in so many words: ``exists(s)`` alone or in a top-level
    ``and`` of a constraint without trigger signals (always evaluated), and ``require``."""
    required: set[str] = set(require)
    for constraint in model.constraints:
        if constraint.triggers:
            continue
        expr = constraint.expr
        parts = expr.operands if isinstance(expr, ir.And) else (expr,)
        required.update(p.signal for p in parts if isinstance(p, ir.Exists))
    return frozenset(required)


def _candidates(prior: SlotPrior, scores: Sequence[float], required: bool) -> list[tuple[int, int]]:
    """Where a slot would like to be: its draw; a required slot drawn absent, its best bins."""
    if prior.present and prior.choice < len(prior.bins):
        return [(prior.start, prior.start + prior.length)]
    if not required or prior.index > 0:
        return []
    order = sorted(range(len(prior.bins)), key=lambda b: -scores[b + 1])
    return [(prior.targets[b], prior.targets[b] + prior.length) for b in order]


def _thinned(
    enc: Encoding,
    priors: Mapping[str, Sequence[SlotPrior]],
    scores: Mapping[tuple[str, int], Sequence[float]],
    required: frozenset[str],
) -> dict[str, list[tuple[int, int]]]:
    """The drawn occurrences, added one by one (required signals first, then from the
    costliest to drop), each kept only if it overlaps nothing in its exclusive modality and
    breaks no further constraint: a quick step towards the optimum, so that the search starts
    from a nearly consistent timeline."""
    model = enc.model
    kept: dict[str, list[tuple[int, int]]] = {}
    busy: dict[str, list[tuple[int, int]]] = {}
    exclusive = model.exclusive_modalities
    touching: dict[str, list[ir.Constraint]] = {}
    for constraint in model.constraints:
        for name in ir.mentioned_signals(constraint.expr):
            touching.setdefault(name, []).append(constraint)
    queue = []
    for name, slots in priors.items():
        for prior in slots:
            if prior.never or (name, prior.index) not in scores:
                continue
            options = scores[(name, prior.index)]
            places = _candidates(prior, options, name in required)
            if places:
                cost = options[prior.choice + 1] - options[0]
                queue.append((name not in required, -cost, name, prior.index, places))
    for _, _, name, _, places in sorted(queue):
        modality = model.signal(name).modality
        taken = busy.setdefault(modality, []) if modality in exclusive else None
        mine = kept.get(name, [])
        checks = touching.get(name, [])
        for interval in places:
            if interval[1] > enc.duration:
                continue
            if taken is not None and any(a < interval[1] and interval[0] < b for a, b in taken):
                continue
            if any(a < interval[1] and interval[0] < b for a, b in mine):
                continue
            before = sum(constraint_status(c, kept, enc.duration) is False for c in checks)
            kept[name] = sorted([*mine, interval])
            if sum(constraint_status(c, kept, enc.duration) is False for c in checks) > before:
                kept[name] = mine
                continue
            if taken is not None:
                taken.append(interval)
            break
        if not kept.get(name):
            kept.pop(name, None)
    return kept


def profile_stages(enc: Encoding, priors: Mapping[str, Sequence[SlotPrior]], seed: int,
                   mode: str = "sample", required: frozenset[str] = frozenset()) -> tuple[Stages, list[Slot], int]:
    """The perturb-and-MAP stages of every window slot (``mode``: sample, likely or random),
    the slots of never-occurring signals, and how low the option terms can go (negated).
    Window slots are hinted with the draw, thinned where it overlaps."""
    rng = random.Random(seed)
    stages = Stages()
    never: list[Slot] = []
    floor = 0
    scored: dict[tuple[str, int], list[float]] = {}
    for signal in enc.model.signals:
        slots = [slot for slot in enc.decided(signal.id) if slot.group == "window"]
        for slot, prior in zip(slots, priors.get(signal.id, ()), strict=False):
            if prior.never:
                never.append(slot)
                continue
            scores = perturbed_scores(prior, rng, mode)
            scored[(signal.id, prior.index)] = scores
            floor += _choice_terms(enc, slot, prior, scores, stages)
    floor += _later_terms(enc, stages, mode)
    kept = _thinned(enc, priors, scored, required)
    for signal in enc.model.signals:
        slots = [slot for slot in enc.decided(signal.id) if slot.group == "window"]
        intervals = kept.get(signal.id, [])
        lengths = [p.length for p in priors.get(signal.id, ())]
        for rank, slot in enumerate(slots):
            if rank < len(intervals):
                hint(enc, slot, intervals[rank][0], intervals[rank][1] - intervals[rank][0])
            else:
                hint(enc, slot, -1, lengths[rank] if rank < len(lengths) else 0)
    return stages, never, floor


def _later_terms(enc: Encoding, stages: Stages, mode: str) -> int:
    """Cost a repetitive signal's not repeating in the rest of the timeline (its second later
    slot absent) at the prior's log-probability of at most one start there, so that a window
    does not commit what stops a signal from repeating for the rest.  Returns how low the
    terms can go (negated).

    Without it a window trades its own options only: under the every-pair reading one
    occurrence of a partner (``equal(start(b), stop(a), 0.3)``) costs a window little but
    allows at most one ``a`` for the rest of an hour, where the prior expects hundreds; the
    target almost never shows that, and the chain after CP-SAT leaves such a state slowly.
    The second slot, not the first: "each signal once more" is itself such a silenced future,
    and weighing the first later slot made windows defer everything to keep it open.  The
    cost is capped at IMPOSSIBLE, the price of any option the prior rules out."""
    if mode == "random" or enc.frame.end is None:
        return 0
    floor = 0
    for signal in enc.model.signals:
        later = [slot for slot in enc.decided(signal.id) if slot.group == "later"]
        if not signal.repetitive or len(later) < 2 or isinstance(later[1].present, bool):
            continue
        expected = sum(expected_starts(signal, enc.duration, lo, hi, enc.frame.end)
                       for lo, hi in window_bins(enc.frame.end, enc.duration))
        # Poisson: -log P(N <= 1) = expected - log(1 + expected).
        units = round(SCALE * min(expected - math.log1p(expected), -IMPOSSIBLE))
        if units > 0:
            stages.first.append(-units * (1 - later[1].present))
            stages.options.append(later[1].present)
            floor += units
    return floor


def preference_terms(enc: Encoding, objective: str, seed: int) -> list[Any]:
    """most-signals / fewest-signals, with seeded tie-breaks that never outweigh one signal."""
    rng = random.Random(seed)
    terms: list[Any] = []
    slot_total = sum(len(enc.decided(s.id)) for s in enc.model.signals)
    big = SCALE * (2 * slot_total + 1)
    sign = 1 if objective == "most-signals" else -1
    for signal in enc.model.signals:
        occurs = enc.occurs[signal.id]
        if not isinstance(occurs, bool):
            terms.append(sign * big * occurs)
        for slot in enc.decided(signal.id):
            terms.append(rng.randint(0, SCALE) * slot.present)
            if sign < 0:
                hint(enc, slot, -1, 0)
    return terms


def set_objective(
    enc: Encoding,
    objective: str | None,
    seed: int,
    priors: Mapping[str, Sequence[SlotPrior]],
    previous: Sequence[Schedule] = (),
    require: Sequence[str] = (),
) -> Stages:
    """Install the first stage of ``objective`` (None: the profile) and return both stages;
    with ``previous`` schedules, add the diversity reward (one stage: positions matter to it)."""
    never: list[Slot] = []
    floor = 0
    if objective in ("most-signals", "fewest-signals"):
        stages = Stages(first=preference_terms(enc, objective, seed))
    else:
        stages, never, floor = profile_stages(enc, priors, seed, objective or "sample",
                                              required_signals(enc.model, require))
    if previous:
        reward, most = _diversity_terms(enc, previous)
        stages.first.extend(reward)
        stages.first.extend(stages.second(enc.cp))
        stages.positions = []
        stages._second = None
        floor += most
    # Lexicographic: one occurrence of a never-occurring signal costs more than every other
    # term of the stage together can gain or lose.
    stages.first.extend(-(floor + 1) * slot.present for slot in never)
    stages.options.extend(slot.present for slot in never)  # stage 2 keeps them absent too
    enc.cp.maximize(sum(stages.first))
    return stages


def _diversity_terms(enc: Encoding, previous: Sequence[Schedule]) -> tuple[list[Any], int]:
    """Reward the smallest distance to the ``previous`` schedules (and, less, their sum).

    Distance: per slot, D if its presence differs, plus |start - previous start| if both
    are present; a slot is compared with the occurrence of the same rank."""
    duration = max(1, enc.duration)
    slot_total = max(1, sum(len(enc.decided(s.id)) for s in enc.model.signals))
    distances = []
    for schedule in previous:
        by_signal = schedule.by_signal()
        parts: list[Any] = []
        for signal in enc.model.signals:
            before = sorted(by_signal.get(signal.id, []))
            for rank, slot in enumerate(enc.decided(signal.id)):
                if rank < len(before):
                    parts.append(duration * (1 - slot.present))
                    moved = enc.cp.new_int_var(0, duration, "")
                    enc.cp.add_abs_equality(moved, slot.start - before[rank].start)
                    parts.append(moved)
                else:
                    parts.append(duration * slot.present)
        total = enc.cp.new_int_var(0, 2 * duration * slot_total, "")
        enc.cp.add(total == sum(parts))
        distances.append(total)
    smallest = enc.cp.new_int_var(0, 2 * duration * slot_total, "")
    for distance in distances:
        enc.cp.add(smallest <= distance)
    # Per tick of distance: DIVERSITY_WEIGHT nats / D, as an integer >= 1.
    per_tick = max(1, round(DIVERSITY_WEIGHT * SCALE / duration))
    most = (2 + len(distances)) * per_tick * 2 * duration * slot_total
    return [2 * per_tick * smallest, *(per_tick * d for d in distances)], most


__all__ = ["ABSENT", "SCALE", "Stages", "hint", "perturbed_scores", "set_objective"]

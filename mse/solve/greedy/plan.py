"""Per-model structures of the greedy sampler, computed once and cached.

A :class:`Plan` holds everything that does not depend on the random draws: tick durations
and occurrence limits of every signal, the time stamps and the probability table, the
compiled constraints indexed by the signals they mention, and the *critical-point edges*
used by the ad-hoc inference (docs/sampler.md): for every comparison between an edge of a
signal and another time, the offset and tolerance that say where its truth may change (read
from the constraints by edges.py, with the necessary start bounds).
"""

from __future__ import annotations

import itertools
import math
import weakref
from collections import OrderedDict
from collections.abc import Sequence
from typing import NamedTuple

from mse.ir import model as ir
from mse.ir.profile import RATE_UNIT
from mse.ir.schedule import to_ticks
from mse.solve.greedy.edges import Edge, StartBound, edges_of, start_bounds_of
from mse.solve.greedy.order import needs_before
from mse.solve.greedy.partial import CompiledConstraint, absent_gate, compiled_constraint

#: Default length of a time stamp in seconds (the original implementation's ~1 s).
DEFAULT_SLOT = 1.0

#: How often a repetitive signal may occur when the model sets no limit: more than fits.
UNBOUNDED = 1 << 30


#: The critical-point rules of one signal and drawn edge (windows.critical_rules): the constant
#: points, the offsets from the candidate's own start, and per partner (signal, box index of
#: the edge's low end, offsets).
CriticalRules = tuple[tuple[int, ...], tuple[int, ...], tuple[tuple[str, int, tuple[int, ...]], ...]]


# Plain classes with __slots__ rather than dataclasses: `mse sample` imports this module at
# start-up, and each dataclass costs about a millisecond to create.
class InitialDebts(NamedTuple):
    """What :meth:`Attempt.refresh_latest` finds on the empty timeline at stamp 0: the same for
    every walk of a plan and request (it draws nothing), so it is computed once."""

    doomed: str | None  # the Doomed message, when no walk can pay
    latest: dict[str, int]
    needs: dict[str, tuple[str, ...]]
    stuck: frozenset[str]
    checked: tuple[str, tuple[int, int, int, int], list[str]] | None
    work: int  # partial checks it made (the walk's work bound counts them on every walk)


class SignalPlan:
    """One signal in ticks: what the walk needs of it."""

    __slots__ = ("exclusive", "id", "index", "limit", "longest", "prior_mass", "probability_end", "probability_start",
                 "profile", "shortest")

    def __init__(
        self, index: int, id: str, shortest: int, longest: int, limit: int, exclusive: str | None,
        probability_start: float, probability_end: float,
    ) -> None:
        self.index = index
        self.id = id
        self.shortest = shortest  # ms, at least 1 (start < stop)
        self.longest = longest  # ms, at most the duration
        self.limit = limit  # occurrences allowed
        self.exclusive = exclusive  # its modality, when that modality is exclusive
        self.probability_start = probability_start
        self.probability_end = probability_end
        # (duration, mass of its starts, occurrence probability): prior_starts_in's constants
        self.prior_mass: tuple[int, float, float] | None = None
        # (stamps, duration, p at the middle of each stamp): _profile's
        self.profile: tuple[Sequence[int], int, list[float]] | None = None


class Plan:
    """Everything about one model, duration and slot that does not depend on the draws."""

    __slots__ = (
        "bounds",
        "by_constraint_id",
        "by_id",
        "by_signal",
        "constraint_ids",
        "constraints",
        "critical",
        "cumulative",
        "duration",
        "edges",
        "enables",
        "enabling_memo",
        "fixed",
        "gated",
        "implied",
        "in_modality",
        "influence",
        "initial_debts",
        "initial_owing",
        "masses",
        "must_exist",
        "narrowable",
        "needs_before",
        "order_free_bounds",
        "order_free_offsets",
        "partner_bounds",
        "partners_of",
        "related",
        "requires",
        "signals",
        "stamps",
        "table",
    )

    def __init__(
        self,
        duration: int,
        stamps: tuple[int, ...],
        table: tuple[tuple[float, ...], ...],
        signals: tuple[SignalPlan, ...],
        constraints: tuple[CompiledConstraint, ...],
        by_signal: dict[str, list[CompiledConstraint]],
        related: dict[str, tuple[str, ...]],
        edges: dict[str, tuple[Edge, ...]],
        bounds: dict[str, tuple[StartBound, ...]],
        columns: Sequence[Sequence[float]] | None = None,
    ) -> None:
        self.duration = duration
        self.stamps = stamps  # t_0 .. t_n (t_n = duration)
        self.table = table  # table[j][k]: probability that signal k is a candidate at stamp j
        # Per signal, the cumulative hazard H[j] = -sum_{i<j} log(1 - table[i][k]): the next
        # stamp at which a signal is a candidate is drawn at once by inverting it (one draw per
        # candidacy instead of one per stamp; the same distribution as a trial per stamp).
        # (``columns``: the table's columns, when the caller has them)
        self.cumulative = tuple(
            _cumulative(columns[s.index] if columns is not None else [row[s.index] for row in table]) for s in signals
        )
        self.signals = signals
        # Per signal, the prefix sums of its profile's mass per stamp (p at the middle x the
        # length): an owed signal is due in stamp j with probability mass_j / (mass of j up to
        # its deadline), so that even a forced start follows the profile (walk.py).
        self.masses = tuple(
            tuple(itertools.accumulate(
                (p * (last - first) for p, (first, last) in zip(
                    _profile(s, stamps, duration), itertools.pairwise(stamps), strict=True)),
                initial=0.0,
            ))
            for s in signals
        )
        self.by_id = {s.id: s for s in signals}
        in_modality: dict[str, list[SignalPlan]] = {}
        for signal in signals:
            if signal.exclusive is not None:
                in_modality.setdefault(signal.exclusive, []).append(signal)
        self.in_modality = {name: tuple(members) for name, members in in_modality.items()}
        self.constraints = constraints
        self.by_constraint_id = {c.id: c for c in constraints}
        # Per constraint, the signals of its top-level ``exists`` conjuncts: while the
        # constraint is owing (instantiated and violated if nothing more occurs) each of them
        # that has not occurred must still occur (Obligations.check_room)
        # (``exists(x) implies exists(y)``, x placed: the consequent's, as long as x's
        # occurrence instantiates the constraint.)
        self.must_exist = {c.id: _must_exist(c.constraint) for c in constraints}
        # Per signal x, the signals that must occur once x does: ``exists(x) implies
        # exists(y) and ...`` (an implies chain; the closure of Obligations.must_occur).
        implied: dict[str, set[str]] = {}
        for compiled in constraints:
            antecedent = _antecedent(compiled.constraint)
            if antecedent is not None:
                implied.setdefault(antecedent, set()).update(_must_exist(compiled.constraint))
        self.implied = {name: tuple(sorted(found)) for name, found in implied.items()}
        # Constraints violated while nothing is placed (every attempt starts owing them).
        self.initial_owing = frozenset(c.id for c in constraints if c.violated({}))
        # (forbid, require) -> the obligations of the empty timeline at stamp 0 (deterministic:
        # no draw), computed by the first walk and reused by the others (Attempt.initial_debts)
        self.initial_debts: dict[tuple[frozenset[str], frozenset[str]], InitialDebts] = {}
        # Lists, reordered by the sampler (most recently failing first: order never changes results)
        self.by_signal = by_signal
        self.constraint_ids = {s.id: frozenset(c.id for c in by_signal[s.id]) for s in signals}
        # Per signal, its constraints with their gate (partial.absent_gate; the signal itself
        # when none): a constraint whose gate does not occur is acceptable whatever the
        # signal does, and State.allows skips its check.  Lists, reordered as by_signal.
        self.gated = {
            s.id: [(absent_gate(c.constraint.expr, s.id) or s.id, c) for c in by_signal[s.id]] for s in signals
        }
        self.related = related  # signals sharing a constraint with it (itself too)
        # Placing a signal may change the checks of the signals related to it and, through the
        # future boxes of its exclusive modality's members, of the signals related to those.
        reach = {
            name: frozenset(n for member in members for n in related[member.id])
            for name, members in self.in_modality.items()
        }
        self.influence = {
            s.id: frozenset(related[s.id]) | (reach[s.exclusive] if s.exclusive is not None else frozenset())
            for s in signals
        }
        self.edges = edges
        # (signal, "start" or "stop") -> its edges compiled for windows.critical_values, filled
        # on first use (engine.Attempt.critical)
        self.critical: dict[tuple[str, str], CriticalRules] = {}
        self.bounds = bounds
        # earliest/latest start from the constant bounds alone
        self.fixed = {s.id: _fixed_window(s, bounds[s.id], duration) for s in signals}
        lengths = {s.id: (s.shortest, s.longest) for s in signals}
        # signals that must be placed before each one can start (order.py)
        self.needs_before = {s.id: needs_before(s.id, by_signal[s.id], lengths, duration) for s in signals}
        # Per signal y, the signals x without which it cannot occur: a constraint that y
        # instantiates holds only if x occurs (``exists(x) and equal(start(y), start(x), 0.3)``,
        # ``exists(y) implies exists(x)``, an ``exists(x)`` in every operand of an ``or``).
        requires: dict[str, set[str]] = {s.id: set() for s in signals}
        for compiled in constraints:
            constraint = compiled.constraint
            antecedent = _antecedent(constraint)
            if antecedent is not None:
                assert isinstance(constraint.expr, ir.Implies)
                requires[antecedent] |= _required(constraint.expr.right)
                continue
            needed = _required(constraint.expr)
            for name in constraint.triggers:
                if name in requires:
                    requires[name] |= needed
        self.requires = {name: frozenset(found - {name}) for name, found in requires.items()}
        # the reverse, for the once-only signals others wait for or cannot occur without:
        # (signal, those that need it)
        enables: dict[str, list[SignalPlan]] = {}
        for s in signals:
            for name in sorted(set(self.needs_before[s.id]) | self.requires[s.id]):
                enables.setdefault(name, []).append(s)
        # (position in enables, stamp, free followers) -> walk.enabling's extra probability
        self.enabling_memo: dict[tuple[int, int, tuple[int, ...]], float] = {}
        self.enables = tuple((self.by_id[name], tuple(found)) for name, found in sorted(enables.items())
                             if self.by_id[name].limit == 1)
        # the bounds that name another signal, grouped by it, as (other, ((box index, delta,
        # upper), ...)) for speed: one lookup of the other's occurrences per partner
        self.partner_bounds = {s.id: _by_partner(bounds[s.id]) for s in signals}
        # the signals whose partner_bounds name each signal: their start windows may move
        # when its occurrences change (State.narrowing)
        partners_of: dict[str, list[str]] = {s.id: [] for s in signals}
        for s in signals:
            for other, _ in self.partner_bounds[s.id]:
                partners_of.setdefault(other, []).append(s.id)
        self.partners_of = {name: tuple(found) for name, found in partners_of.items()}
        # the same, holding whichever of the two starts first (Obligations.check_room
        # propagates them between signals not placed yet)
        # signal -> the signals a placement of it may narrow (engine._narrowable), on first use
        self.narrowable: dict[str, tuple[tuple[str, SignalPlan, tuple[str, ...]], ...]] = {}
        self.order_free_bounds = {
            s.id: _by_partner(start_bounds_of(s, by_signal[s.id], duration, placed_first=False)) for s in signals
        }
        # the same as (other, ((upper, offset), ...)): a bound on the other's stop counts its
        # longest length in an upper bound, its shortest in a lower one
        self.order_free_offsets = {
            name: tuple(
                (other, tuple((upper, delta + (lengths[other][1 if upper else 0] if index == 2 else 0))
                              for index, delta, upper in rules))
                for other, rules in found
            )
            for name, found in self.order_free_bounds.items()
        }

    def stamp_of(self, tick: int) -> int:
        """Index j of the stamp [t_j, t_{j+1}) holding ``tick``."""
        n = len(self.stamps) - 1
        j = min(n - 1, tick * n // self.duration) if self.duration else 0
        while j > 0 and self.stamps[j] > tick:
            j -= 1
        while j < n - 1 and self.stamps[j + 1] <= tick:
            j += 1
        return j


def _antecedent(constraint: ir.Constraint) -> str | None:
    """x of ``exists(x) implies ...`` when x's occurrence instantiates the constraint (x is a
    trigger, or there is none), else None."""
    expr = constraint.expr
    if isinstance(expr, ir.Implies) and isinstance(expr.left, ir.Exists):
        name = expr.left.signal
        if not constraint.triggers or name in constraint.triggers:
            return name
    return None


def _must_exist(constraint: ir.Constraint) -> tuple[str, ...]:
    """The signals that must occur while ``constraint`` is owing (instantiated, violated if
    nothing more occurs): its top-level ``exists`` conjuncts; for ``exists(x) implies R``,
    owing means x occurred, so R's."""
    if _antecedent(constraint) is not None:
        assert isinstance(constraint.expr, ir.Implies)
        return _top_level_exists(constraint.expr.right)
    return _top_level_exists(constraint.expr)


def _required(expr: ir.Expr) -> set[str]:
    """The signals that must occur for ``expr`` to hold (``exists`` conjuncts; in an ``or``,
    those every operand requires)."""
    if isinstance(expr, ir.Exists):
        return {expr.signal}
    if isinstance(expr, ir.And):
        return {name for operand in expr.operands for name in _required(operand)}
    if isinstance(expr, ir.Or):
        found = [_required(operand) for operand in expr.operands]
        return set.intersection(*found) if found else set()
    return set()


def _top_level_exists(expr: ir.Expr) -> tuple[str, ...]:
    if isinstance(expr, ir.Exists):
        return (expr.signal,)
    if isinstance(expr, ir.And):
        return tuple(sorted({name for operand in expr.operands for name in _top_level_exists(operand)}))
    return ()


def _mass(signal: SignalPlan, x0: int, x1: int, duration: int) -> float:
    """Integral of the profile p(u) du over the ticks [x0, x1)."""
    a, b = signal.probability_start, signal.probability_end
    u0, u1 = x0 / duration, x1 / duration
    return a * (u1 - u0) + (b - a) * (u1 * u1 - u0 * u0) / 2


def prior_starts_in(signal: SignalPlan, starts: Sequence[tuple[int, int]], low: int, duration: int) -> float:
    """Probability that the prior alone starts ``signal`` in ``starts`` (intervals of ticks,
    inclusive), given that it is free from ``low`` (a once-only one: not started before)."""
    # _mass(signal, x0, x1, duration) written out below (the same operations: the same floats)
    a = signal.probability_start
    change = signal.probability_end - a
    if signal.limit > 1:
        # a start within a free second with probability p: intensity -ln(1 - p) per second
        hazard = 0.0
        for lo, hi in starts:
            span = (hi + 1 - lo) / duration
            u0, u1 = lo / duration, (hi + 1) / duration
            mean = (a * (u1 - u0) + change * (u1 * u1 - u0 * u0) / 2) / span
            hazard -= math.log1p(-(mean if mean < 0.999999 else 0.999999)) * span * duration / 1000
        return 1.0 - math.exp(-hazard)
    cached = signal.prior_mass
    if cached is not None and cached[0] == duration:
        total, occurs = cached[1], cached[2]
    else:
        total = _mass(signal, 0, duration - signal.shortest + 1, duration)
        occurs = min(1.0, (signal.probability_start + signal.probability_end) / 2)
        signal.prior_mass = (duration, total, occurs)
    if total <= 0:
        return 0.0
    u1 = low / duration
    left = 1.0 - occurs * (a * (u1 - 0.0) + change * (u1 * u1 - 0.0 * 0.0) / 2) / total
    masses = []
    for lo, hi in starts:
        u0, u1 = lo / duration, (hi + 1) / duration
        masses.append(a * (u1 - u0) + change * (u1 * u1 - u0 * u0) / 2)
    pays = occurs * sum(masses) / total / max(1e-12, left)
    return min(1.0, max(0.0, pays))


def _cumulative(hazards: Sequence[float]) -> tuple[float, ...]:
    total, found = 0.0, [0.0]
    log1p, certain = math.log1p, 1.0 - 1e-12  # a certain candidacy: 1 - 1e-12
    for hazard in hazards:
        total -= log1p(-(hazard if hazard <= certain else certain))  # (min, written out)
        found.append(total)
    return tuple(found)


# per partner: (box index, delta, upper) of each necessary start bound with it
PartnerBounds = tuple[tuple[str, tuple[tuple[int, int, bool], ...]], ...]


def _by_partner(bounds: Sequence[StartBound]) -> PartnerBounds:
    grouped: dict[str, list[tuple[int, int, bool]]] = {}
    for bound in bounds:
        if bound.other is not None:
            grouped.setdefault(bound.other, []).append((bound.box_index, bound.delta, bound.upper))
    return tuple((other, tuple(rules)) for other, rules in grouped.items())


def _fixed_window(signal: SignalPlan, bounds: Sequence[StartBound], duration: int) -> tuple[int, int]:
    first, last = 0, duration - signal.shortest
    for bound in bounds:
        if bound.other is None:
            if bound.upper:
                last = min(last, bound.delta)
            else:
                first = max(first, bound.delta)
    return first, last


def _signal_plan(index: int, signal: ir.Signal, duration: int, exclusive: frozenset[str]) -> SignalPlan:
    longest = duration if signal.max_duration is None else min(duration, to_ticks(signal.max_duration))
    limit = 1
    if signal.repetitive:
        limit = UNBOUNDED if signal.max_occurrences is None else signal.max_occurrences
    return SignalPlan(
        index=index,
        id=signal.id,
        shortest=max(1, to_ticks(signal.min_duration)),
        longest=longest,
        limit=limit,
        exclusive=signal.modality if signal.modality in exclusive else None,
        probability_start=signal.probability_start,
        probability_end=signal.probability_end,
    )


def _profile(signal: SignalPlan, stamps: Sequence[int], duration: int) -> list[float]:
    """``p(u)`` at the middle of every stamp (mse.ir.profile: the straight line over u = t / D);
    kept on the signal for its plan's stamps (the hazards and the masses both read it)."""
    kept = signal.profile
    if kept is not None and kept[0] is stamps and kept[1] == duration:
        return kept[2]
    found = _profile_of(signal, stamps, duration)
    signal.profile = (stamps, duration, found)
    return found


def _profile_of(signal: SignalPlan, stamps: Sequence[int], duration: int) -> list[float]:
    start, end = signal.probability_start, signal.probability_end
    change = end - start
    found = []
    for middle in _middles(stamps):
        # min(1.0, max(0.0, p)) written out (the same value, -0.0 included)
        p = start + change * middle / duration
        found.append(0.0 if p <= 0.0 else 1.0 if p > 1.0 else p)
    return found


#: The last stamps' middles (one tuple, read once: safe across threads).
_last_middles: tuple[Sequence[int], list[float]] | None = None


def _middles(stamps: Sequence[int]) -> list[float]:
    """The middle of every stamp (the last stamps' kept: a plan asks for them per signal)."""
    global _last_middles
    entry = _last_middles
    if entry is not None and entry[0] is stamps:
        return entry[1]
    middles = [(first + last) / 2 for first, last in itertools.pairwise(stamps)]
    _last_middles = (stamps, middles)
    return middles


def _hazards(signal: SignalPlan, stamps: Sequence[int], duration: int) -> list[float]:
    """Per-stamp probability that a still available signal is a candidate (mse/ir/profile.py,
    docs/sampler.md).

    Repetitive signals: ``1 - (1 - p(u))^(stamp length in seconds)``, so that a free second
    holds a start with probability ``p(u)`` whatever the stamp length.  Signals that occur
    once: the hazard that makes "starts in stamp j" have probability
    ``occurrence_probability * mass_j`` where ``mass_j`` is the stamp's share of the integral
    of ``p(u)`` (the start density is proportional to the profile over the whole span)."""
    profile = _profile(signal, stamps, duration)
    # Only the starts where its shortest length fits count (the prior of docs/semantics.md, as
    # bench/evaluation/reference.py draws it): a once-only signal's mass spread over the
    # stamps past ``duration - shortest`` lost those candidacies (a 1/1 signal of >= 2.6 s
    # occurred in 81 % of 10 s timelines instead of all); a repetitive one's whole last
    # stamp of hazard fell on its last possible start.
    end = duration - signal.shortest + 1
    lengths = []
    for first, second in itertools.pairwise(stamps):  # max(0, min(end, second) - first)
        length = (end if end < second else second) - first
        lengths.append(length if length > 0 else 0)
    if signal.limit > 1:
        unit = RATE_UNIT * 1000
        return [1.0 - (1.0 - p) ** (length / unit) for p, length in zip(profile, lengths, strict=True)]
    masses = [p * length for p, length in zip(profile, lengths, strict=True)]
    total = sum(masses)
    if total <= 0:
        return [0.0] * len(masses)
    occurs = min(1.0, (signal.probability_start + signal.probability_end) / 2)  # occurrence_probability
    hazards, used = [], 0.0
    for mass in masses:
        share = occurs * mass / total
        left = 1.0 - used
        hazards.append(min(1.0, share / left) if left > 1e-12 else 0.0)
        used += share
    return hazards


def build_plan(model: ir.Model, duration: int, slot: float, with_constraints: bool = True) -> Plan:
    """Everything the sampler needs for ``model`` at ``duration`` ms with ``slot``-second stamps."""
    count = max(1, round(duration / max(1, to_ticks(slot))))
    stamps = tuple(round(j * duration / count) for j in range(count + 1))
    signals = tuple(_signal_plan(i, s, duration, model.exclusive_modalities) for i, s in enumerate(model.signals))
    columns = [_hazards(s, stamps, duration) for s in signals]
    table = tuple(tuple(column[j] for column in columns) for j in range(count))
    # Constraints that say the same thing (Greta's sets repeat some) are checked once: the
    # walk's verdicts are the same, and the final check names every violated one anyway.
    kept = _distinct(model.constraints) if with_constraints else ()
    constraints = tuple(compiled_constraint(c, duration) for c in kept)
    by_signal = {s.id: [c for c in constraints if s.id in c.mentioned] for s in signals}
    related = {
        s.id: tuple(sorted({name for c in by_signal[s.id] for name in c.mentioned} | {s.id})) for s in signals
    }
    edges = {s.id: edges_of(s.id, by_signal[s.id], duration) for s in signals}
    bounds = {s.id: start_bounds_of(s, by_signal[s.id], duration) for s in signals}
    return Plan(
        duration=duration,
        stamps=stamps,
        table=table,
        signals=signals,
        constraints=constraints,
        by_signal=by_signal,
        related=related,
        edges=edges,
        bounds=bounds,
        columns=columns,
    )


# Per tuple of constraints (identity; the entry holds it, so its id is not reused): the first
# of each distinct expression, in order.  Hashing every expression again for each plan cost a
# tenth of building one (a dialogue builds one per episode).
_DISTINCT: dict[int, tuple[tuple[ir.Constraint, ...], tuple[ir.Constraint, ...]]] = {}
_DISTINCT_LIMIT = 1024


def _distinct(constraints: tuple[ir.Constraint, ...]) -> tuple[ir.Constraint, ...]:
    entry = _DISTINCT.get(id(constraints))
    if entry is not None and entry[0] is constraints:
        return entry[1]
    distinct = {c.expr: c for c in reversed(constraints)}
    kept = tuple(c for c in constraints if distinct.get(c.expr) is c)
    if len(_DISTINCT) >= _DISTINCT_LIMIT:
        _DISTINCT.clear()
    _DISTINCT[id(constraints)] = (constraints, kept)
    return kept


# A model is cached by identity (hashing a whole model per call would cost more than it saves);
# the weak reference drops the entry's meaning when the model is garbage collected.  The least
# recently used plan goes first.  A caller that plans a length once (a dialogue's announced
# episode, mse live) asks for no caching: 256 such plans held ~27 MB.
_CACHE: OrderedDict[tuple[int, int, float, bool], tuple[weakref.ref[ir.Model], Plan]] = OrderedDict()
_CACHE_LIMIT = 32


def plan_for(model: ir.Model, duration: int, slot: float, with_constraints: bool = True, *,
             cache: bool = True) -> Plan:
    key = (id(model), duration, slot, with_constraints)
    entry = _CACHE.get(key)
    if entry is not None and entry[0]() is model:
        _CACHE.move_to_end(key)
        return entry[1]
    plan = build_plan(model, duration, slot, with_constraints)
    if not cache:
        return plan
    _CACHE[key] = (weakref.ref(model), plan)
    while len(_CACHE) > _CACHE_LIMIT:
        _CACHE.popitem(last=False)
    return plan

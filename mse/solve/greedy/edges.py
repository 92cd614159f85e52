"""What a signal's constraints say about its edges (plan.py computes these once per model):
the *critical-point edges* of the ad-hoc inference (docs/sampler.md) -- for every comparison
between an edge of the signal and another time, the offset and tolerance that say where its
truth may change -- and the *necessary start bounds* that reject hopeless candidates cheaply.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple, Protocol

from mse.ir import model as ir
from mse.ir.relations import COMPARISONS, RELATIONS, Bound, Endpoint, known_time
from mse.solve.greedy.partial import CompiledConstraint


class SignalLengths(Protocol):
    """What the start bounds need of a signal (plan.SignalPlan has it): its id and its
    shortest and longest length in ticks."""

    id: str
    shortest: int
    longest: int


class Edge(NamedTuple):
    """``edge(me) + my_offset  ~  other`` where other is ``edge(other_signal) + other_offset``
    or, when ``other_signal`` is None, the constant ``other_offset``."""

    my_edge: str
    my_offset: int
    other_signal: str | None
    other_edge: str
    other_offset: int
    tolerance: int


class StartBound(NamedTuple):
    """A necessary bound on the start of a signal: ``start <= / >= edge(other) + delta`` for
    every placed occurrence of ``other`` (or the constant ``delta`` when other is None).

    Derived from atoms that are the whole constraint or a top-level conjunct: once the signal
    occurs the constraint is instantiated, and with ``other`` placed the atom cannot be
    unknown, so it must hold.  Checking these first rejects hopeless candidates cheaply."""

    other: str | None
    box_index: int  # 0: start of other, 2: stop of other
    delta: int
    upper: bool


def _term_edge(term: ir.Term, duration: int) -> tuple[str | None, str, int]:
    if isinstance(term, ir.SignalTime):
        return term.signal, term.edge, term.offset
    return None, "", known_time(term, duration)


def _signal_time(atom: ir.Relation, end: Endpoint) -> ir.SignalTime:
    return ir.SignalTime(atom.left if end.side == "left" else atom.right, end.edge)


def _comparisons(atom: ir.Atom, duration: int) -> list[tuple[ir.Term, ir.Term, int]]:
    """The edge comparisons an atom is made of (relations decomposed: the bounds of their
    meaning in mse.ir.relations, in its order), with tolerance."""
    if isinstance(atom, ir.Compare):
        return [(atom.left, atom.right, atom.tolerance)]
    if isinstance(atom, ir.Exists):
        return []
    return [(_signal_time(atom, b.lower), _signal_time(atom, b.upper), 0) for b in RELATIONS[atom.kind].bounds]


# Per constraint expression, what does not depend on the duration: its edge comparisons in
# walk order, and its top-level conjuncts.  A model's plan is built again for every duration (a
# dialogue plans each episode once): these are read once per expression.  Keyed by identity;
# each entry holds its expression, so an id is not reused while its entry lives.
_PER_EXPR: dict[int, _ExprParts] = {}
_PER_EXPR_LIMIT = 4096
_PER_EXPR_BOUNDS = 256


class _ExprParts:
    """One constraint expression's duration-free parts."""

    __slots__ = ("compare_bounds", "conjuncts", "expr", "mine", "relation_bounds")

    def __init__(self, expr: ir.Expr) -> None:
        self.expr = expr
        # per signal, (its edge, the other term, tolerance) of every comparison naming it, in
        # the order edges_of always read them (walk order; left then right)
        self.mine: dict[str, list[tuple[ir.SignalTime, ir.Term, int]]] = {}
        for node in ir.walk(expr):
            if isinstance(node, ir.Exists | ir.Relation | ir.Compare):
                for left, right, tolerance in _comparisons(node, 0):  # (the duration is not used)
                    for mine, other in ((left, right), (right, left)):
                        if isinstance(mine, ir.SignalTime):
                            self.mine.setdefault(mine.signal, []).append((mine, other, tolerance))
        self.conjuncts = tuple(_conjuncts(expr))
        # (conjunct index, signal id, shortest) -> _relation_bounds of that conjunct
        self.relation_bounds: dict[tuple[int, str, int], list[StartBound]] = {}
        # (conjunct index, signal id, shortest, longest, -1) -> _compare_bounds of a conjunct
        # between two signals (with a constant, the duration plays a part: not kept)
        self.compare_bounds: dict[tuple[int, str, int, int, int], list[StartBound]] = {}


def _expr_parts(expr: ir.Expr) -> _ExprParts:
    entry = _PER_EXPR.get(id(expr))
    if entry is not None and entry.expr is expr:
        return entry
    if len(_PER_EXPR) >= _PER_EXPR_LIMIT:
        _PER_EXPR.clear()
    entry = _PER_EXPR[id(expr)] = _ExprParts(expr)
    return entry


def edges_of(signal_id: str, constraints: Sequence[CompiledConstraint], duration: int) -> tuple[Edge, ...]:
    found: dict[Edge, None] = {}
    for compiled in constraints:
        for mine, other, tolerance in _expr_parts(compiled.constraint.expr).mine.get(signal_id, ()):
            other_signal, other_edge, other_offset = _term_edge(other, duration)
            found[Edge(mine.edge, mine.offset, other_signal, other_edge, other_offset, tolerance)] = None
    return tuple(found)


def _conjuncts(expr: ir.Expr) -> list[ir.Expr]:
    if isinstance(expr, ir.And):
        return [part for operand in expr.operands for part in _conjuncts(operand)]
    return [expr]


def _bound(me: SignalLengths, mine: ir.SignalTime, other: ir.Term, limit: int, upper: bool,
           duration: int) -> StartBound:
    """The bound on start(me) from ``mine - other <= limit`` (``upper``) or ``other - mine <=
    limit``.  A bound on the stop bounds the start through the length: stop <= x gives
    start <= x - shortest, stop >= x gives start >= x - longest."""
    if isinstance(other, ir.SignalTime):
        name: str | None = other.signal
        index, base = (0 if other.edge == "start" else 2), other.offset - mine.offset
    else:
        name, index = None, 0
        base = known_time(other, duration) - mine.offset
    if upper:
        return StartBound(name, index, base + limit - (0 if mine.edge == "start" else me.shortest), True)
    return StartBound(name, index, base - limit - (0 if mine.edge == "start" else me.longest), False)


def _before_partner_start(bound: Bound[Endpoint], mine: str) -> bool:
    """``my edge - partner's start <= slack`` cannot hold once the partner started no later
    than me: my stop is after my start, so only ``my start = partner's start`` may."""
    if bound.lower.side != mine or bound.upper.edge != "start" or bound.slack is None:
        return False
    return bound.slack < 0 or (bound.lower.edge == "stop" and bound.slack <= 0)


def _relation_bounds(atom: ir.Relation, me: SignalLengths) -> list[StartBound]:
    """Bounds on start(me) from a relation with a placed partner.  Placed occurrences start
    no later than any new one (starts never decrease): of a disjunction, the bounds that
    would put my start or stop before the partner's start cannot hold, and when one bound
    is left it must.  A lower bound through my stop (start >= x - longest) is not taken
    from relations (comparisons give it): the sampler's windows, hence its outputs for a
    seed, stay what they were."""
    if atom.left == atom.right:
        return []
    meaning = RELATIONS[atom.kind]
    mine = "left" if atom.left == me.id else "right"
    between = [b for b in meaning.bounds if (b.lower.side == mine) != (b.upper.side == mine)]
    possible = between
    if meaning.joined == "or" and len(meaning.bounds) > 1:
        if len(between) < len(meaning.bounds):  # a bound within one signal may hold instead
            return []
        possible = [b for b in between if not _before_partner_start(b, mine)]
        if len(possible) != 1:
            return []
    found = []
    for bound in possible:
        upper = bound.lower.side == mine
        my_end, other_end = (bound.lower, bound.upper) if upper else (bound.upper, bound.lower)
        if not upper and my_end.edge == "stop":
            continue
        limit = bound.limit(0)
        found.append(_bound(me, _signal_time(atom, my_end), _signal_time(atom, other_end), limit, upper, 0))
    return found


def _compare_bounds(atom: ir.Compare, me: SignalLengths, duration: int) -> list[StartBound]:
    """Bounds on start(me) from a comparison of one of its edges with a placed partner or a
    constant: each bound of the comparison's meaning (mse.ir.relations) that names my edge."""
    for mine, side in ((atom.left, "left"), (atom.right, "right")):
        if not (isinstance(mine, ir.SignalTime) and mine.signal == me.id):
            continue
        other = atom.right if side == "left" else atom.left
        if isinstance(other, ir.SignalTime) and other.signal == me.id:
            return []
        found = [
            _bound(me, mine, other, bound.limit(atom.tolerance), bound.lower == side, duration)
            for bound in COMPARISONS[atom.op].bounds
        ]
        return sorted(found, key=lambda b: b.upper)  # lower bounds first, as they always were
    return []


def start_bounds_of(
    signal: SignalLengths, constraints: Sequence[CompiledConstraint], duration: int, *, placed_first: bool = True
) -> tuple[StartBound, ...]:
    """The necessary start bounds of ``signal``.  ``placed_first``: the partner is placed
    before it (as in the walk's state); without it, only the bounds that hold in any order
    (a relation that is a disjunction, ``excludes``, gives none)."""
    found: dict[StartBound, None] = {}
    for compiled in constraints:
        parts = _expr_parts(compiled.constraint.expr)
        for position, atom in enumerate(parts.conjuncts):
            if isinstance(atom, ir.Relation) and signal.id in (atom.left, atom.right):
                meaning = RELATIONS[atom.kind]
                if not placed_first and meaning.joined == "or" and len(meaning.bounds) > 1:
                    continue
                # it reads only the atom, the signal's id and its shortest length (a bound
                # through its stop that would read the longest one is not taken from relations)
                key = (position, signal.id, signal.shortest)
                bounds = parts.relation_bounds.get(key)
                if bounds is None:
                    bounds = parts.relation_bounds[key] = _relation_bounds(atom, signal)
                found.update(dict.fromkeys(bounds))
            elif isinstance(atom, ir.Compare):
                # it reads the atom, the signal's id and lengths, and the duration only for a
                # term that names no signal
                between = isinstance(atom.left, ir.SignalTime) and isinstance(atom.right, ir.SignalTime)
                compare_key = (position, signal.id, signal.shortest, signal.longest, -1 if between else duration)
                bounds = parts.compare_bounds.get(compare_key)
                if bounds is None:
                    bounds = _compare_bounds(atom, signal, duration)
                    if between:  # (kept only when the duration plays no part)
                        if len(parts.compare_bounds) >= _PER_EXPR_BOUNDS:
                            # (a signal without a longest length has the duration's: a dialogue
                            # would add one per episode)
                            parts.compare_bounds.clear()
                        parts.compare_bounds[compare_key] = bounds
                found.update(dict.fromkeys(bounds))
    return tuple(found)

"""What a signal's constraints say about its edges (plan.py computes these once per model):
the *critical-point edges* of the ad-hoc inference (docs/sampler.md) -- for every comparison
between an edge of the signal and another time, the offset and tolerance that say where its
truth may change -- and the *necessary start bounds* that reject hopeless candidates cheaply.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple, Protocol

from mse.ir import model as ir
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
    if isinstance(term, ir.DurationTime):
        return None, "", duration + term.offset
    return None, "", term.value


def _comparisons(atom: ir.Atom, duration: int) -> list[tuple[ir.Term, ir.Term, int]]:
    """The edge comparisons an atom is made of (relations decomposed), with tolerance."""
    if isinstance(atom, ir.Compare):
        return [(atom.left, atom.right, atom.tolerance)]
    if isinstance(atom, ir.Exists):
        return []
    a_start, a_stop = ir.SignalTime(atom.left, "start"), ir.SignalTime(atom.left, "stop")
    b_start, b_stop = ir.SignalTime(atom.right, "start"), ir.SignalTime(atom.right, "stop")
    pairs = {
        "includes": [(a_start, b_start), (b_stop, a_stop)],
        "excludes": [(a_stop, b_start), (b_stop, a_start)],
        "precedes": [(a_stop, b_start)],
        "rightincludes": [(a_start, b_stop), (b_stop, a_stop)],
    }[atom.kind]
    return [(left, right, 0) for left, right in pairs]


def edges_of(signal_id: str, constraints: Sequence[CompiledConstraint], duration: int) -> tuple[Edge, ...]:
    found: dict[Edge, None] = {}
    for compiled in constraints:
        for node in ir.walk(compiled.constraint.expr):
            if not isinstance(node, ir.Exists | ir.Relation | ir.Compare):
                continue
            for left, right, tolerance in _comparisons(node, duration):
                for mine, other in ((left, right), (right, left)):
                    if isinstance(mine, ir.SignalTime) and mine.signal == signal_id:
                        other_signal, other_edge, other_offset = _term_edge(other, duration)
                        edge = Edge(mine.edge, mine.offset, other_signal, other_edge, other_offset, tolerance)
                        found[edge] = None
    return tuple(found)


def _conjuncts(expr: ir.Expr) -> list[ir.Expr]:
    if isinstance(expr, ir.And):
        return [part for operand in expr.operands for part in _conjuncts(operand)]
    return [expr]


def _relation_bounds(atom: ir.Relation, me: str, shortest: int) -> list[StartBound]:
    """Bounds on start(me) from a relation with a placed partner.  Placed occurrences start
    no later than any new one (starts never decrease), which settles the disjunctions."""
    if atom.left == atom.right:
        return []
    mine_left = atom.left == me
    other = atom.right if mine_left else atom.left
    start, stop = 0, 2
    if atom.kind == "excludes":  # the partner started first: it must have stopped
        return [StartBound(other, stop, 0, False)]
    if atom.kind == "precedes":
        if mine_left:  # me.stop <= other.start <= me.start: impossible
            return [StartBound(other, start, -shortest, True)]
        return [StartBound(other, stop, 0, False)]
    if atom.kind == "includes":
        if mine_left:
            return [StartBound(other, start, 0, True)]
        return [StartBound(other, start, 0, False), StartBound(other, stop, -shortest, True)]
    if mine_left:  # rightincludes(me, other): me.start <= other.stop
        return [StartBound(other, stop, 0, True)]
    return [StartBound(other, stop, -shortest, True)]  # other.start <= me.stop <= other.stop


_FLIP = {"<": ">", ">": "<", "<=": ">=", ">=": "<=", "=": "="}


def _compare_bounds(atom: ir.Compare, me: SignalLengths, duration: int) -> list[StartBound]:
    """Bounds on start(me) from a comparison of one of its edges with a placed partner or a
    constant.  A bound on the stop bounds the start through the length: stop <= x gives
    start <= x - shortest, stop >= x gives start >= x - longest."""
    for mine, other, op in ((atom.left, atom.right, atom.op), (atom.right, atom.left, _FLIP[atom.op])):
        if not (isinstance(mine, ir.SignalTime) and mine.signal == me.id):
            continue
        upper_shift, lower_shift = (0, 0) if mine.edge == "start" else (me.shortest, me.longest)
        if isinstance(other, ir.SignalTime):
            if other.signal == me.id:
                return []
            name: str | None = other.signal
            index, base = (0 if other.edge == "start" else 2), other.offset - mine.offset
        else:
            name, index = None, 0
            base = (duration + other.offset if isinstance(other, ir.DurationTime) else other.value) - mine.offset
        if op == "<":
            return [StartBound(name, index, base - 1 - upper_shift, True)]
        if op == "<=":
            return [StartBound(name, index, base - upper_shift, True)]
        if op == ">":
            return [StartBound(name, index, base + 1 - lower_shift, False)]
        if op == ">=":
            return [StartBound(name, index, base - lower_shift, False)]
        tolerance = atom.tolerance
        return [StartBound(name, index, base - tolerance - lower_shift, False),
                StartBound(name, index, base + tolerance - upper_shift, True)]
    return []


def start_bounds_of(
    signal: SignalLengths, constraints: Sequence[CompiledConstraint], duration: int
) -> tuple[StartBound, ...]:
    found: dict[StartBound, None] = {}
    for compiled in constraints:
        for atom in _conjuncts(compiled.constraint.expr):
            if isinstance(atom, ir.Relation) and signal.id in (atom.left, atom.right):
                found.update(dict.fromkeys(_relation_bounds(atom, signal.id, signal.shortest)))
            elif isinstance(atom, ir.Compare):
                found.update(dict.fromkeys(_compare_bounds(atom, signal, duration)))
    return tuple(found)

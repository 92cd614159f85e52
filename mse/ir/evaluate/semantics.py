"""The semantics of docs/semantics.md, atom by atom: three-valued truth (``True``, ``False``,
``None`` for unknown), relational and comparison atoms over integer-millisecond intervals,
strong Kleene connectives, and whether a constraint is instantiated, satisfied or violated.
Whole timelines are :mod:`mse.ir.evaluate`'s (the one entry point).
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence

from mse.ir import model as ir
from mse.ir.relations import COMPARISONS, EDGE_INDEX, RELATIONS, known_time

Truth = bool | None
Intervals = Mapping[str, Sequence[tuple[int, int]]]


# -- atoms ------------------------------------------------------------------------------------
def relation_holds(kind: str, a: tuple[int, int], b: tuple[int, int]) -> bool:
    """``kind(a, b)`` for one interval of each signal (the table of mse.ir.relations)."""
    intervals = {"left": a, "right": b}
    return RELATIONS[kind].holds(lambda end: intervals[end.side][EDGE_INDEX[end.edge]])


def _term_value(term: ir.Term, chosen: Mapping[str, tuple[int, int]], duration: int) -> int:
    if isinstance(term, ir.SignalTime):
        return chosen[term.signal][EDGE_INDEX[term.edge]] + term.offset
    return known_time(term, duration)


def compare_holds(op: str, left: int, right: int, tolerance: int = 0) -> bool:
    """``left op right`` (the table of mse.ir.relations)."""
    values = {"left": left, "right": right}
    return COMPARISONS[op].holds(values.__getitem__, tolerance)


def evaluate_atom(atom: ir.Atom, intervals: Intervals, duration: int) -> Truth:
    if isinstance(atom, ir.Exists):
        return bool(intervals.get(atom.signal))
    names = tuple(dict.fromkeys(ir.atom_signals(atom)))
    pools = [intervals.get(name, ()) for name in names]
    if any(not pool for pool in pools):
        return None
    for combination in itertools.product(*pools):
        chosen = dict(zip(names, combination, strict=True))
        if isinstance(atom, ir.Relation):
            holds = relation_holds(atom.kind, chosen[atom.left], chosen[atom.right])
        else:
            left = _term_value(atom.left, chosen, duration)
            right = _term_value(atom.right, chosen, duration)
            holds = compare_holds(atom.op, left, right, atom.tolerance)
        if not holds:
            return False
    return True


# -- connectives --------------------------------------------------------------------------------
def kleene_not(value: Truth) -> Truth:
    return None if value is None else not value


def kleene_and(values: Sequence[Truth]) -> Truth:
    if any(v is False for v in values):
        return False
    return None if any(v is None for v in values) else True


def kleene_or(values: Sequence[Truth]) -> Truth:
    if any(v is True for v in values):
        return True
    return None if any(v is None for v in values) else False


def evaluate_expr(expr: ir.Expr, intervals: Intervals, duration: int) -> Truth:
    if isinstance(expr, ir.Not):
        return kleene_not(evaluate_expr(expr.operand, intervals, duration))
    if isinstance(expr, ir.And):
        return kleene_and([evaluate_expr(e, intervals, duration) for e in expr.operands])
    if isinstance(expr, ir.Or):
        return kleene_or([evaluate_expr(e, intervals, duration) for e in expr.operands])
    if isinstance(expr, ir.Implies):
        left = evaluate_expr(expr.left, intervals, duration)
        return kleene_or([kleene_not(left), evaluate_expr(expr.right, intervals, duration)])
    return evaluate_atom(expr, intervals, duration)


def is_instantiated(constraint: ir.Constraint, intervals: Intervals) -> bool:
    """False when the constraint has trigger signals and none of them occurs (ignored)."""
    triggers = constraint.triggers
    return not triggers or any(intervals.get(signal) for signal in triggers)


def constraint_status(constraint: ir.Constraint, intervals: Intervals, duration: int) -> Truth:
    """True (satisfied), False (violated) or None (ignored or unknown, both fine)."""
    if not is_instantiated(constraint, intervals):
        return None
    return evaluate_expr(constraint.expr, intervals, duration)


def is_violated(constraint: ir.Constraint, intervals: Intervals, duration: int) -> bool:
    return constraint_status(constraint, intervals, duration) is False

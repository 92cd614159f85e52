"""Static ordering facts of a model for the greedy walk: which signals must already be placed
before a signal can start (docs/sampler.md, "Prerequisites").

A constraint ``c`` in which signal ``s`` is a trigger (it names ``s`` in a relational atom),
with a top-level conjunct ``exists(p)`` and a top-level conjunct relating the edges of ``s``
and ``p`` only, is instantiated as soon as ``s`` is placed, so ``p`` must occur; if that
relation cannot hold when ``p`` starts no earlier than ``s`` (as every later placement does:
starts never decrease), ``p`` must be placed *before* ``s``.  Example: ``exists(b) and
equal(start(c), stop(b), 0.3)`` — ``c`` cannot start until ``b`` is placed.  The walk then
skips ``c``'s candidacy at once (the check would fail anyway: an exact shortcut), and the
deadlines treat ``b`` as due before ``c``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from mse.ir import model as ir
from mse.solve.greedy.closures import compile_expr
from mse.solve.greedy.masks import T
from mse.solve.greedy.partial import CompiledConstraint


def _conjuncts(expr: ir.Expr) -> list[ir.Expr]:
    if isinstance(expr, ir.And):
        return [part for operand in expr.operands for part in _conjuncts(operand)]
    return [expr]


def _only_between(atom: ir.Expr, me: str, other: str) -> bool:
    if isinstance(atom, ir.Relation):
        return {atom.left, atom.right} == {me, other}
    if isinstance(atom, ir.Compare):
        terms = (atom.left, atom.right)
        return all(isinstance(t, ir.SignalTime) for t in terms) and {t.signal for t in terms} == {me, other}  # type: ignore[union-attr]
    return False


def needs_before(
    signal: str, constraints: Sequence[CompiledConstraint], lengths: Mapping[str, tuple[int, int]], duration: int
) -> tuple[str, ...]:
    """Signals that must be placed before ``signal`` can start (``lengths``: shortest and
    longest occurrence of every signal, in ms)."""
    found: set[str] = set()
    shortest, longest = lengths[signal]
    mine = (0, 0, shortest, longest)  # the signal starting at 0 (relative time)
    for compiled in constraints:
        if signal not in compiled.triggers:
            continue
        parts = _conjuncts(compiled.constraint.expr)
        required = {p.signal for p in parts if isinstance(p, ir.Exists) and p.signal != signal}
        for other in required:
            theirs = (0, duration, lengths[other][0], duration)  # starting no earlier than it
            env = {signal: [mine], other: [theirs]}
            for part in parts:
                if _only_between(part, signal, other) and not compile_expr(part, duration)(env) & T:
                    found.add(other)
                    break
    return tuple(sorted(found))

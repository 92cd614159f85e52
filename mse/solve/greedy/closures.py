"""Constraint expressions compiled to closures over possible-times boxes (partial.py's exact
and lifted evaluations; docs/sampler.md, "Checking a partial animation").

:func:`compile_expr` gives, for one environment (each signal's boxes), the set of truth values
an expression may take; :func:`lift` the same for a state where some signals may or may not get
one more occurrence, atom by atom.  The mask arithmetic is masks.py's.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

from mse.ir import model as ir
from mse.ir.relations import known_time
from mse.solve.greedy.codegen import generate
from mse.solve.greedy.masks import (
    AND_TABLE,
    COMPARE_FOLDS,
    COMPARE_MASKS,
    HIGH,
    IMPLIES_TABLE,
    LOW,
    NOT_TABLE,
    OR_TABLE,
    RELATION_FOLDS,
    RELATION_MASKS,
    Box,
    Env,
    F,
    N,
    Node,
    T,
    edge_span,
    for_each_pair,
    mask_and,
    mask_or,
)


# -- compiling expressions to closures -----------------------------------------------------------
def _edge_indices(term: ir.Term) -> tuple[int, int, int]:
    """Box indices of the low and high value of a signal edge, and its offset."""
    assert isinstance(term, ir.SignalTime)
    return LOW[term.edge], HIGH[term.edge], term.offset


def _compile_compare(atom: ir.Compare, duration: int) -> Node:
    left_signal = atom.left.signal if isinstance(atom.left, ir.SignalTime) else None
    right_signal = atom.right.signal if isinstance(atom.right, ir.SignalTime) else None
    tolerance, left, right = atom.tolerance, atom.left, atom.right
    compare_mask, fold_compare = COMPARE_MASKS[atom.op], COMPARE_FOLDS[atom.op]

    if left_signal is None and right_signal is None:
        a, b = known_time(left, duration), known_time(right, duration)
        constant = compare_mask(a, a, b, b, tolerance)
        return lambda env: constant
    if left_signal is None or right_signal is None:
        name = left_signal or right_signal
        assert name is not None
        on_left = left_signal is not None
        low, high, offset = _edge_indices(left if on_left else right)
        value = known_time(right if on_left else left, duration)

        def one_box(a: Box) -> int:
            if on_left:
                return compare_mask(a[low] + offset, a[high] + offset, value, value, tolerance)
            return compare_mask(value, value, a[low] + offset, a[high] + offset, tolerance)

        fixed = (value, value, value, value)

        def one(env: Env) -> int:
            boxes = env.get(name)
            if not boxes:
                return N
            if len(boxes) == 1:
                return one_box(boxes[0])
            span = edge_span(boxes, low, high, offset)
            if on_left:
                return fold_compare(span, fixed, tolerance)
            return fold_compare(fixed, span, tolerance)

        return one
    same = left_signal == right_signal
    a_low, a_high, a_offset = _edge_indices(left)
    b_low, b_high, b_offset = _edge_indices(right)

    def pair(a: Box, b: Box) -> int:
        return compare_mask(
            a[a_low] + a_offset, a[a_high] + a_offset, b[b_low] + b_offset, b[b_high] + b_offset, tolerance
        )

    def two(env: Env) -> int:
        lefts, rights = env.get(left_signal), env.get(right_signal)
        if not lefts or not rights:
            return N
        if len(lefts) == 1 and len(rights) == 1:
            return pair(lefts[0], lefts[0] if same else rights[0])
        if same:
            return for_each_pair(pair, lefts)
        return fold_compare(
            edge_span(lefts, a_low, a_high, a_offset), edge_span(rights, b_low, b_high, b_offset), tolerance
        )

    return two


def _compile_relation(atom: ir.Relation) -> Node:
    holds, left, right, same = RELATION_MASKS[atom.kind], atom.left, atom.right, atom.left == atom.right
    fold = RELATION_FOLDS[atom.kind]

    def node(env: Env) -> int:
        lefts, rights = env.get(left), env.get(right)
        if not lefts or not rights:
            return N
        if len(lefts) == 1 and len(rights) == 1:  # the usual case: one occurrence each
            return holds(lefts[0], lefts[0] if same else rights[0])
        if same:
            return for_each_pair(holds, lefts)
        return fold(lefts, rights)

    return node


def compile_expr(expr: ir.Expr, duration: int) -> Node:
    """A closure computing the possible truth values of ``expr`` in an environment."""
    if isinstance(expr, ir.Exists):
        name = expr.signal
        return lambda env: T if env.get(name) else F
    if isinstance(expr, ir.Relation):
        return _compile_relation(expr)
    if isinstance(expr, ir.Compare):
        return _compile_compare(expr, duration)
    if isinstance(expr, ir.Not):
        inner, negation = compile_expr(expr.operand, duration), NOT_TABLE
        return lambda env: negation[inner(env)]
    if isinstance(expr, ir.Implies):
        premise, conclusion = compile_expr(expr.left, duration), compile_expr(expr.right, duration)
        implies = IMPLIES_TABLE
        return lambda env: implies[premise(env) << 3 | conclusion(env)]
    parts = [compile_expr(e, duration) for e in ir.children(expr)]
    if len(parts) == 2:
        first, second = parts
        table = AND_TABLE if isinstance(expr, ir.And) else OR_TABLE
        return lambda env: table[first(env) << 3 | second(env)]
    combine = mask_and if isinstance(expr, ir.And) else mask_or
    return lambda env: combine([part(env) for part in parts])


_TABLES = {"NOT": NOT_TABLE, "AND": AND_TABLE, "OR": OR_TABLE, "IMPLIES": IMPLIES_TABLE, "AND_MANY": mask_and,
           "OR_MANY": mask_or}


def generated(expr: ir.Expr, triggers: tuple[str, ...] | None, duration: int) -> Callable[[Env], int]:
    """``compile_expr`` (``triggers`` None) or ``_acceptance`` as one generated function
    (codegen.py): the same values, without a call per node."""
    return generate(expr, triggers, lambda atom: compile_expr(atom, duration), _TABLES)



def lift(expr: ir.Expr, duration: int) -> Callable[[Env, Mapping[str, Box]], int]:
    """Like :func:`compile_expr`, for a state where each signal of ``maybe`` may or may not
    get one more occurrence (its box), independently per atom: the union of the atom's
    values over its own worlds.  Sound (every world's value is included) but it forgets the
    correlation between atoms, so it is only used to prune the search over worlds."""
    if isinstance(expr, ir.Exists):
        name = expr.signal
        return lambda env, maybe: T if env.get(name) else (T | F if name in maybe else F)
    if isinstance(expr, ir.Relation | ir.Compare):
        exact, names = compile_expr(expr, duration), tuple(dict.fromkeys(ir.atom_signals(expr)))

        def atom(env: Env, maybe: Mapping[str, Box]) -> int:
            relevant = [name for name in names if name in maybe]
            if not relevant:
                return exact(env)
            local: dict[str, Sequence[Box]] = {name: env.get(name) or () for name in names}
            mask = 0
            for bits in range(1 << len(relevant)):
                for index, name in enumerate(relevant):
                    base = env.get(name) or ()
                    local[name] = [*base, maybe[name]] if bits >> index & 1 else base
                mask |= exact(local)
            return mask

        return atom
    if isinstance(expr, ir.Not):
        inner = lift(expr.operand, duration)
        return lambda env, maybe: NOT_TABLE[inner(env, maybe)]
    if isinstance(expr, ir.Implies):
        premise, conclusion = lift(expr.left, duration), lift(expr.right, duration)
        return lambda env, maybe: IMPLIES_TABLE[premise(env, maybe) << 3 | conclusion(env, maybe)]
    parts = [lift(e, duration) for e in ir.children(expr)]
    combine = mask_and if isinstance(expr, ir.And) else mask_or
    return lambda env, maybe: combine([part(env, maybe) for part in parts])

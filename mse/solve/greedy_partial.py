"""Partial-timeline evaluation for the greedy sampler (docs/sampler.md, "Checking a partial
animation").

The sampler places signals in order of start time, so at any moment the timeline is a
*partial animation*: placed occurrences with exact times, perhaps one candidate whose stop is
not chosen yet, and signals that may still occur later, never earlier than the current
frontier.  This module answers "can this constraint still end up satisfied?" for such a state.

Every occurrence is a box ``(start_lo, start_hi, stop_lo, stop_hi)`` of possible times
(placed occurrences are points).  An atom evaluates to the *set* of truth values it may take,
a bit mask of ``T`` (true), ``F`` (false) and ``N`` (unknown: a signal it names never
occurs); strong Kleene connectives are lifted to these sets.  The correlation that matters
most -- ``exists(a)`` and the relational atoms naming ``a`` depend on the same fact, whether
``a`` occurs -- is kept exact by enumerating *worlds*: each signal that may still occur is
either absent for good or gets one more occurrence box.  Within a world the lifting treats
atoms independently, so the answer over-approximates ("may be satisfiable"): the sampler can
accept a doomed state (caught by the final check, then it restarts) but never rejects a
state that the semantics would accept once complete.  On complete timelines (only points, no
worlds) the masks are single values and the evaluation is exactly :mod:`mse.ir.evaluate`'s
(tests/test_greedy_partial.py checks that).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

from mse.ir import model as ir

T, F, N = 1, 2, 4
#: A possible-times box: (start_lo, start_hi, stop_lo, stop_hi) in ms.
Box = tuple[int, int, int, int]
Env = Mapping[str, Sequence[Box]]
Node = Callable[[Env], int]

#: Worlds are enumerated over at most this many optional signals per constraint; a
#: constraint naming more optional signals is accepted unchecked (the final check decides).
MAX_WORLD_SIGNALS = 5


def mask_not(mask: int) -> int:
    return ((mask & T) << 1) | ((mask & F) >> 1) | (mask & N)


def mask_and(masks: Sequence[int]) -> int:
    every, some, true_or_unknown = T | F | N, 0, True
    for mask in masks:
        every &= mask
        some |= mask
        if not mask & (T | N):
            true_or_unknown = False
    return (every & T) | (some & F) | (N if true_or_unknown and some & N else 0)


def mask_or(masks: Sequence[int]) -> int:
    every, some, false_or_unknown = T | F | N, 0, True
    for mask in masks:
        every &= mask
        some |= mask
        if not mask & (F | N):
            false_or_unknown = False
    return (some & T) | (every & F) | (N if false_or_unknown and some & N else 0)


# -- interval comparisons: the truth values ``a op b`` may take for a in [alo, ahi], b in
# [blo, bhi] ----------------------------------------------------------------------------------
def compare_mask(op: str, alo: int, ahi: int, blo: int, bhi: int, tolerance: int = 0) -> int:
    if op == "<=":
        return (T if alo <= bhi else 0) | (F if ahi > blo else 0)
    if op == "<":
        return (T if alo < bhi else 0) | (F if ahi >= blo else 0)
    if op == ">=":
        return (T if ahi >= blo else 0) | (F if alo < bhi else 0)
    if op == ">":
        return (T if ahi > blo else 0) | (F if alo <= bhi else 0)
    low, high = alo - bhi, ahi - blo  # the range of a - b
    may_true = low <= tolerance and high >= -tolerance
    may_false = low < -tolerance or high > tolerance
    return (T if may_true else 0) | (F if may_false else 0)


def _both(first: int, second: int) -> int:
    return (T if first & second & T else 0) | ((first | second) & F)


def _either(first: int, second: int) -> int:
    return ((first | second) & T) | (F if first & second & F else 0)


def _le(alo: int, ahi: int, blo: int, bhi: int) -> int:
    return (T if alo <= bhi else 0) | (F if ahi > blo else 0)


def _precedes(a: Box, b: Box) -> int:
    return (T if a[2] <= b[1] else 0) | (F if a[3] > b[0] else 0)


def _includes(a: Box, b: Box) -> int:
    return _both(_le(a[0], a[1], b[0], b[1]), _le(b[2], b[3], a[2], a[3]))


def _excludes(a: Box, b: Box) -> int:
    return _either(_le(a[2], a[3], b[0], b[1]), _le(b[2], b[3], a[0], a[1]))


def _rightincludes(a: Box, b: Box) -> int:
    return _both(_le(a[0], a[1], b[2], b[3]), _le(b[2], b[3], a[2], a[3]))


RELATION_MASKS: dict[str, Callable[[Box, Box], int]] = {
    "precedes": _precedes,
    "includes": _includes,
    "excludes": _excludes,
    "rightincludes": _rightincludes,
}


def relation_mask(kind: str, a: Box, b: Box) -> int:
    """Truth values of ``kind(a, b)`` for one occurrence box of each signal."""
    return RELATION_MASKS[kind](a, b)


# -- compiling expressions to closures -----------------------------------------------------------
def _for_all(pairs_mask: Callable[[Box, Box], int], left: Sequence[Box], right: Sequence[Box], same: bool) -> int:
    """Fold "holds for every combination of occurrences" over the boxes."""
    if len(left) == 1 and (same or len(right) == 1):
        return pairs_mask(left[0], left[0] if same else right[0])
    may_true, may_false = True, False
    if same:
        combos: Sequence[tuple[Box, Box]] = [(box, box) for box in left]
    else:
        combos = [(a, b) for a in left for b in right]
    for a, b in combos:
        mask = pairs_mask(a, b)
        may_true = may_true and bool(mask & T)
        may_false = may_false or bool(mask & F)
    return (T if may_true else 0) | (F if may_false else 0)


def _term_range(term: ir.Term, box: Box | None, duration: int) -> tuple[int, int]:
    if isinstance(term, ir.SignalTime):
        assert box is not None
        if term.edge == "start":
            return box[0] + term.offset, box[1] + term.offset
        return box[2] + term.offset, box[3] + term.offset
    value = duration + term.offset if isinstance(term, ir.DurationTime) else term.value
    return value, value


def _compile_compare(atom: ir.Compare, duration: int) -> Node:
    left_signal = atom.left.signal if isinstance(atom.left, ir.SignalTime) else None
    right_signal = atom.right.signal if isinstance(atom.right, ir.SignalTime) else None
    op, tolerance, left, right = atom.op, atom.tolerance, atom.left, atom.right

    def pair(a: Box | None, b: Box | None) -> int:
        alo, ahi = _term_range(left, a, duration)
        blo, bhi = _term_range(right, b, duration)
        return compare_mask(op, alo, ahi, blo, bhi, tolerance)

    if left_signal is None and right_signal is None:
        constant = pair(None, None)
        return lambda env: constant
    if left_signal is None or right_signal is None:
        name = left_signal or right_signal
        assert name is not None
        on_left = left_signal is not None

        def one(env: Env) -> int:
            boxes = env.get(name)
            if not boxes:
                return N
            return _for_all(lambda a, _b: pair(a, None) if on_left else pair(None, a), boxes, boxes, True)

        return one
    same = left_signal == right_signal

    def two(env: Env) -> int:
        lefts, rights = env.get(left_signal), env.get(right_signal)
        if not lefts or not rights:
            return N
        return _for_all(pair, lefts, rights, same)

    return two


def _compile_relation(atom: ir.Relation) -> Node:
    holds, left, right, same = RELATION_MASKS[atom.kind], atom.left, atom.right, atom.left == atom.right

    def node(env: Env) -> int:
        lefts, rights = env.get(left), env.get(right)
        if not lefts or not rights:
            return N
        return _for_all(holds, lefts, rights, same)

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
        inner = compile_expr(expr.operand, duration)
        return lambda env: mask_not(inner(env))
    if isinstance(expr, ir.Implies):
        premise, conclusion = compile_expr(expr.left, duration), compile_expr(expr.right, duration)
        return lambda env: mask_or((mask_not(premise(env)), conclusion(env)))
    parts = [compile_expr(e, duration) for e in ir.children(expr)]
    combine = mask_and if isinstance(expr, ir.And) else mask_or
    if len(parts) == 2:
        first, second = parts
        return lambda env: combine((first(env), second(env)))
    return lambda env: combine([part(env) for part in parts])


class CompiledConstraint:
    """One constraint, compiled for a timeline of ``duration`` ms."""

    __slots__ = ("constraint", "mentioned", "node", "triggers")

    def __init__(self, constraint: ir.Constraint, duration: int) -> None:
        self.constraint = constraint
        self.node = compile_expr(constraint.expr, duration)
        self.triggers = tuple(sorted(constraint.triggers))
        self.mentioned = tuple(sorted(ir.mentioned_signals(constraint.expr)))

    def acceptable(self, env: Env) -> bool:
        """In this one world: ignored, or may end up true or unknown (not surely false)."""
        if self.triggers:
            for name in self.triggers:
                if env.get(name):
                    break
            else:
                return True
        return bool(self.node(env) & (T | N))

    def violated(self, env: Env) -> bool:
        """On a complete timeline (points only): exactly :func:`mse.ir.evaluate.is_violated`."""
        return not self.acceptable(env)

    def may_hold(self, env: Env, optional: Mapping[str, Box]) -> bool:
        """Some world (each optional signal absent, or present once more in its box) is
        acceptable.  The world where nothing more occurs is tried first (the usual answer)."""
        return self.acceptable(env) or self.in_other_world(env, optional)

    def in_other_world(self, env: Env, optional: Mapping[str, Box]) -> bool:
        """:meth:`may_hold` without the world where nothing more occurs."""
        names = [s for s in self.mentioned if s in optional]
        if len(names) > MAX_WORLD_SIGNALS:
            return True
        for bits in range(1, 1 << len(names)):
            world = dict(env)
            for index, name in enumerate(names):
                if bits >> index & 1:
                    world[name] = [*env.get(name, ()), optional[name]]
            if self.acceptable(world):
                return True
        return False

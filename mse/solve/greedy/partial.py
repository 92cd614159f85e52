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

from bisect import bisect_right
from collections.abc import Callable, Mapping, Sequence
from operator import itemgetter
from typing import Any

from mse.ir import model as ir
from mse.solve.greedy.codegen import generate

T, F, N = 1, 2, 4
#: A possible-times box: (start_lo, start_hi, stop_lo, stop_hi) in ms.
Box = tuple[int, int, int, int]
Env = Mapping[str, Sequence[Box]]
Node = Callable[[Env], int]

#: Worlds are enumerated over at most this many optional signals per constraint; for more,
#: the lifted evaluation decides (``CompiledConstraint.in_other_world``).
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


# Masks are 3-bit sets, so the connectives on one or two masks are table lookups (the
# partial check runs tens of thousands of times per second): NOT_TABLE[m], AND_TABLE[a << 3 | b].
NOT_TABLE = tuple(mask_not(m) for m in range(8))
AND_TABLE = tuple(mask_and((a, b)) for a in range(8) for b in range(8))
OR_TABLE = tuple(mask_or((a, b)) for a in range(8) for b in range(8))
#: ``a implies b`` is ``not a or b``.
IMPLIES_TABLE = tuple(mask_or((mask_not(a), b)) for a in range(8) for b in range(8))


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


def _precedes(a: Box, b: Box) -> int:
    return (T if a[2] <= b[1] else 0) | (F if a[3] > b[0] else 0)


# Each relation below is two interval comparisons ``x <= y`` (T if lo(x) <= hi(y), F if
# hi(x) > lo(y)) joined by "and" (T needs both, F either) or "or" (T needs either, F both),
# written out because this is the hot path.
def _includes(a: Box, b: Box) -> int:
    # start(a) <= start(b) and stop(b) <= stop(a)
    return (T if a[0] <= b[1] and b[2] <= a[3] else 0) | (F if a[1] > b[0] or b[3] > a[2] else 0)


def _excludes(a: Box, b: Box) -> int:
    # stop(a) <= start(b) or stop(b) <= start(a)
    return (T if a[2] <= b[1] or b[2] <= a[1] else 0) | (F if a[3] > b[0] and b[3] > a[0] else 0)


def _rightincludes(a: Box, b: Box) -> int:
    # start(a) <= stop(b) and stop(b) <= stop(a)
    return (T if a[0] <= b[3] and b[2] <= a[3] else 0) | (F if a[1] > b[2] or b[3] > a[2] else 0)


RELATION_MASKS: dict[str, Callable[[Box, Box], int]] = {
    "precedes": _precedes,
    "includes": _includes,
    "excludes": _excludes,
    "rightincludes": _rightincludes,
}


def relation_mask(kind: str, a: Box, b: Box) -> int:
    """Truth values of ``kind(a, b)`` for one occurrence box of each signal."""
    return RELATION_MASKS[kind](a, b)


# -- folds over several occurrences ---------------------------------------------------------------
# A relational atom over signals with several occurrences holds for every combination of them:
# true is possible when every pair may be true, false when some pair may be false.  Each
# relation but excludes is a conjunction of ``x <= y`` comparisons, so the fold only needs the
# smallest and largest value of each box component; excludes is a sweep (or binary searches)
# over both lists.  The components of a signal's boxes never decrease along its list
# (occurrences of one signal are placed in start order and never overlap; a box still to be
# decided comes last and starts after them), so the smallest and largest values are the
# first and last box's.  A repetitive signal may occur hundreds of times in a long timeline:
# this keeps a check's cost flat.
def _spans(boxes: Sequence[Box]) -> tuple[tuple[int, int], tuple[int, int], tuple[int, int], tuple[int, int]]:
    """(min, max) of each of the four box components: the first and the last box's, since the
    components never decrease along the list (see above)."""
    first, last = boxes[0], boxes[-1]
    return (first[0], last[0]), (first[1], last[1]), (first[2], last[2]), (first[3], last[3])


def _sweep_overlaps(left: Sequence[Box], right: Sequence[Box], lo: int, hi: int) -> bool:
    """Some pair has ``left[i][hi] > right[j][lo]`` and ``right[j][hi] > left[i][lo]``; both
    lists have nondecreasing components.  A merge of the two lists, or, when one is much
    shorter, a binary search in the longer one per box of the shorter (the first box of the
    longer ending after this one starts is the only one that can overlap it first)."""
    if len(left) > len(right):
        left, right, lo, hi = right, left, lo, hi
    if len(left) * 8 < len(right):
        key = itemgetter(hi)
        for box in left:
            index = bisect_right(right, box[lo], key=key)
            if index < len(right) and right[index][lo] < box[hi]:
                return True
        return False
    i = j = 0
    while i < len(left) and j < len(right):
        a, b = left[i], right[j]
        if a[hi] <= b[lo]:
            i += 1
        elif b[hi] <= a[lo]:
            j += 1
        else:
            return True
    return False


def _fold_relation(kind: str, left: Sequence[Box], right: Sequence[Box]) -> int:
    if kind == "excludes":
        # T: no pair with a[2] > b[1] and b[2] > a[1]; F: some pair with a[3] > b[0] and b[3] > a[0]
        may_true = not _sweep_overlaps(left, right, 1, 2)
        may_false = _sweep_overlaps(left, right, 0, 3)
        return (T if may_true else 0) | (F if may_false else 0)
    a, b = _spans(left), _spans(right)
    if kind == "precedes":  # a.stop <= b.start
        return (T if a[2][1] <= b[1][0] else 0) | (F if a[3][1] > b[0][0] else 0)
    if kind == "includes":  # a.start <= b.start and b.stop <= a.stop
        return ((T if a[0][1] <= b[1][0] and b[2][1] <= a[3][0] else 0)
                | (F if a[1][1] > b[0][0] or b[3][1] > a[2][0] else 0))
    # rightincludes: a.start <= b.stop and b.stop <= a.stop
    return ((T if a[0][1] <= b[3][0] and b[2][1] <= a[3][0] else 0)
            | (F if a[1][1] > b[2][0] or b[3][1] > a[2][0] else 0))


def _fold_compare(op: str, left: tuple[int, int, int, int], right: tuple[int, int, int, int], tolerance: int) -> int:
    """``x op y`` for every x of ``left`` and y of ``right``, each given as (min of the low
    ends, max of the low ends, min of the high ends, max of the high ends)."""
    a_min_lo, a_max_lo, a_min_hi, a_max_hi = left
    b_min_lo, b_max_lo, b_min_hi, b_max_hi = right
    if op == "<=":
        return (T if a_max_lo <= b_min_hi else 0) | (F if a_max_hi > b_min_lo else 0)
    if op == "<":
        return (T if a_max_lo < b_min_hi else 0) | (F if a_max_hi >= b_min_lo else 0)
    if op == ">=":
        return (T if a_min_hi >= b_max_lo else 0) | (F if a_min_lo < b_max_hi else 0)
    if op == ">":
        return (T if a_min_hi > b_max_lo else 0) | (F if a_min_lo <= b_max_hi else 0)
    may_true = a_max_lo - b_min_hi <= tolerance and a_min_hi - b_max_lo >= -tolerance
    may_false = a_min_lo - b_max_hi < -tolerance or a_max_hi - b_min_lo > tolerance
    return (T if may_true else 0) | (F if may_false else 0)


def _edge_span(boxes: Sequence[Box], low: int, high: int, offset: int) -> tuple[int, int, int, int]:
    """(min low, max low, min high, max high) of one edge: first and last box (see above)."""
    first, last = boxes[0], boxes[-1]
    return first[low] + offset, last[low] + offset, first[high] + offset, last[high] + offset


def _for_each(pairs_mask: Callable[[Box, Box], int], boxes: Sequence[Box]) -> int:
    """Fold over the pairs (box, box): an atom naming one signal twice (same occurrence)."""
    may_true, may_false = True, False
    for box in boxes:
        mask = pairs_mask(box, box)
        may_true = may_true and bool(mask & T)
        may_false = may_false or bool(mask & F)
    return (T if may_true else 0) | (F if may_false else 0)


# -- compiling expressions to closures -----------------------------------------------------------
def _term_range(term: ir.Term, box: Box | None, duration: int) -> tuple[int, int]:
    if isinstance(term, ir.SignalTime):
        assert box is not None
        if term.edge == "start":
            return box[0] + term.offset, box[1] + term.offset
        return box[2] + term.offset, box[3] + term.offset
    value = duration + term.offset if isinstance(term, ir.DurationTime) else term.value
    return value, value


def _edge_indices(term: ir.Term) -> tuple[int, int, int]:
    """Box indices of the low and high value of a signal edge, and its offset."""
    assert isinstance(term, ir.SignalTime)
    return (0, 1, term.offset) if term.edge == "start" else (2, 3, term.offset)


def _compile_compare(atom: ir.Compare, duration: int) -> Node:
    left_signal = atom.left.signal if isinstance(atom.left, ir.SignalTime) else None
    right_signal = atom.right.signal if isinstance(atom.right, ir.SignalTime) else None
    op, tolerance, left, right = atom.op, atom.tolerance, atom.left, atom.right

    if left_signal is None and right_signal is None:
        alo, ahi = _term_range(left, None, duration)
        blo, bhi = _term_range(right, None, duration)
        constant = compare_mask(op, alo, ahi, blo, bhi, tolerance)
        return lambda env: constant
    if left_signal is None or right_signal is None:
        name = left_signal or right_signal
        assert name is not None
        on_left = left_signal is not None
        low, high, offset = _edge_indices(left if on_left else right)
        value, _ = _term_range(right if on_left else left, None, duration)

        def one_box(a: Box) -> int:
            if on_left:
                return compare_mask(op, a[low] + offset, a[high] + offset, value, value, tolerance)
            return compare_mask(op, value, value, a[low] + offset, a[high] + offset, tolerance)

        fixed = (value, value, value, value)

        def one(env: Env) -> int:
            boxes = env.get(name)
            if not boxes:
                return N
            if len(boxes) == 1:
                return one_box(boxes[0])
            span = _edge_span(boxes, low, high, offset)
            if on_left:
                return _fold_compare(op, span, fixed, tolerance)
            return _fold_compare(op, fixed, span, tolerance)

        return one
    same = left_signal == right_signal
    a_low, a_high, a_offset = _edge_indices(left)
    b_low, b_high, b_offset = _edge_indices(right)

    def pair(a: Box, b: Box) -> int:
        return compare_mask(
            op, a[a_low] + a_offset, a[a_high] + a_offset, b[b_low] + b_offset, b[b_high] + b_offset, tolerance
        )

    def two(env: Env) -> int:
        lefts, rights = env.get(left_signal), env.get(right_signal)
        if not lefts or not rights:
            return N
        if len(lefts) == 1 and len(rights) == 1:
            return pair(lefts[0], lefts[0] if same else rights[0])
        if same:
            return _for_each(pair, lefts)
        return _fold_compare(
            op, _edge_span(lefts, a_low, a_high, a_offset), _edge_span(rights, b_low, b_high, b_offset), tolerance
        )

    return two


def _compile_relation(atom: ir.Relation) -> Node:
    holds, left, right, same = RELATION_MASKS[atom.kind], atom.left, atom.right, atom.left == atom.right
    kind = atom.kind

    def node(env: Env) -> int:
        lefts, rights = env.get(left), env.get(right)
        if not lefts or not rights:
            return N
        if len(lefts) == 1 and len(rights) == 1:  # the usual case: one occurrence each
            return holds(lefts[0], lefts[0] if same else rights[0])
        if same:
            return _for_each(holds, lefts)
        return _fold_relation(kind, lefts, rights)

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


def _generated(expr: ir.Expr, triggers: tuple[str, ...] | None, duration: int) -> Callable[[Env], int]:
    """``compile_expr`` (``triggers`` None) or ``_acceptance`` as one generated function
    (codegen.py): the same values, without a call per node."""
    return generate(expr, triggers, lambda atom: compile_expr(atom, duration), _TABLES)


def absent_gate(expr: ir.Expr, signal: str) -> str | None:
    """A signal other than ``signal`` that every atom of ``expr`` names, if any (the first
    in order): while it does not occur, every atom is unknown, so the whole expression is
    unknown (the connectives map unknown operands to unknown) and the constraint acceptable
    whatever ``signal`` does.  None when an atom is an ``exists`` or names no such signal."""
    common: set[str] | None = None
    for node in ir.walk(expr):
        if isinstance(node, ir.Exists):
            return None
        if isinstance(node, ir.Relation | ir.Compare):
            names = set(ir.atom_signals(node)) - {signal}
            common = names if common is None else common & names
            if not common:
                return None
    return min(common) if common else None


#: A constraint's check (or an operand's) runs as closures for its first HOT_CALLS calls, then
#: as the function generated for it (codegen.py): generating costs about as much as a hundred
#: closure calls, which a check called a few times (a one-off timeline, a huge set) never
#: pays back.  Both give the same values: when the switch happens changes no result.
HOT_CALLS = 64


def _hot(closure: Callable[[Env], Any], make: Callable[[], Callable[[Env], Any]],
         install: Callable[[Callable[[Env], Any]], None]) -> Callable[[Env], Any]:
    """``closure``, counting its calls; at the HOT_CALLS-th, ``install(make())``."""
    calls = 0

    def counting(env: Env) -> Any:
        nonlocal calls
        calls += 1
        if calls == HOT_CALLS:
            install(make())
        return closure(env)

    return counting


def _acceptance(triggers: tuple[str, ...], node: Node) -> Callable[[Env], bool | int]:
    """``acceptable`` of :class:`CompiledConstraint`, specialised on the number of triggers.
    Its value is only used for its truth (a non-zero mask is true: no ``bool()`` call)."""
    maybe = T | N
    if not triggers:
        return lambda env: node(env) & maybe
    if len(triggers) == 1:
        (only,) = triggers
        return lambda env: not env.get(only) or node(env) & maybe
    first, second, *rest = triggers
    if not rest:
        return lambda env: not (env.get(first) or env.get(second)) or node(env) & maybe

    def acceptable(env: Env) -> bool | int:
        for name in triggers:
            if env.get(name):
                return node(env) & maybe
        return True

    return acceptable


def _lift(expr: ir.Expr, duration: int) -> Callable[[Env, Mapping[str, Box]], int]:
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
        inner = _lift(expr.operand, duration)
        return lambda env, maybe: NOT_TABLE[inner(env, maybe)]
    if isinstance(expr, ir.Implies):
        premise, conclusion = _lift(expr.left, duration), _lift(expr.right, duration)
        return lambda env, maybe: IMPLIES_TABLE[premise(env, maybe) << 3 | conclusion(env, maybe)]
    parts = [_lift(e, duration) for e in ir.children(expr)]
    combine = mask_and if isinstance(expr, ir.And) else mask_or
    return lambda env, maybe: combine([part(env, maybe) for part in parts])


#: Nodes of the search for an accepting world naming more than MAX_WORLD_SIGNALS optional
#: signals (:meth:`CompiledConstraint.accepting_world`, for prerequisites); past it: none found.
WORLD_BUDGET = 64


class _OutOfBudget(Exception):
    pass


def _some_world(
    node: Node, world: dict[str, Sequence[Box]], env: Env, names: Sequence[str], optional: Mapping[str, Box]
) -> bool:
    """Some world of ``names`` (each absent, or present once more in its ``optional`` box)
    makes ``node`` true or unknown.  ``world`` is a copy of ``env`` (the node reads only the
    signals it names), left as it was."""
    maybe = T | N
    if node(env) & maybe:  # the world where none of them occurs more: env itself
        return True
    extended = [[*(env.get(name) or ()), optional[name]] for name in names]
    try:
        for bits in range(1, 1 << len(names)):
            for index, name in enumerate(names):
                if bits >> index & 1:
                    world[name] = extended[index]
                else:
                    base = env.get(name)
                    if base:
                        world[name] = base
                    else:
                        world.pop(name, None)
            if node(world) & maybe:
                return True
        return False
    finally:
        for name in names:
            base = env.get(name)
            if base is None:
                world.pop(name, None)
            else:
                world[name] = base


class CompiledConstraint:
    """One constraint, compiled for a timeline of ``duration`` ms."""

    __slots__ = (
        "_lifted", "acceptable", "constraint", "duration", "id", "mentioned", "node", "parts", "parts_or", "shared",
        "triggers",
    )

    def __init__(self, constraint: ir.Constraint, duration: int) -> None:
        self.constraint = constraint
        self.id = constraint.id
        self.duration = duration
        self.node = compile_expr(constraint.expr, duration)
        self.triggers = tuple(sorted(constraint.triggers))
        self.mentioned = tuple(sorted(ir.mentioned_signals(constraint.expr)))
        #: In this one world: ignored (no trigger occurs), or may end up true or unknown
        #: (not surely false); true or false in the sense of ``if``.  A closure rather than
        #: a method: it is the hottest call.
        self.acceptable = _hot(
            _acceptance(self.triggers, self.node),
            lambda: _generated(constraint.expr, self.triggers, duration),
            lambda generated: setattr(self, "acceptable", generated),
        )
        self._lifted: Callable[[Env, Mapping[str, Box]], int] | None = None
        # A top-level "or" / "and": its operands, each with the signals it names, so that the
        # worlds of operands naming different optional signals are searched one operand at a
        # time (in_other_world): sum instead of product.
        expr = constraint.expr
        self.parts_or = isinstance(expr, ir.Or)
        self.parts: list[tuple[Node, tuple[str, ...]]] = []
        if isinstance(expr, ir.Or | ir.And) and len(expr.operands) > 1:
            for index, part in enumerate(expr.operands):
                self.parts.append((_hot(
                    compile_expr(part, duration),
                    lambda part=part: _generated(part, None, duration),  # type: ignore[misc]
                    lambda generated, index=index: self._install_part(index, generated),  # type: ignore[misc]
                ), tuple(sorted(ir.mentioned_signals(part)))))
        # signals named by two operands or more: when one of them is optional, the operands'
        # worlds are not independent
        named = [name for _, mentioned in self.parts for name in mentioned]
        self.shared = tuple(sorted({name for name in named if named.count(name) > 1}))

    def _install_part(self, index: int, node: Node) -> None:
        self.parts[index] = (node, self.parts[index][1])

    def violated(self, env: Env) -> bool:
        """On a complete timeline (points only): exactly :func:`mse.ir.evaluate.is_violated`."""
        return not self.acceptable(env)

    def may_hold(self, env: Env, optional: Mapping[str, Box]) -> bool:
        """Some world (each optional signal absent, or present once more in its box) is
        acceptable.  The world where nothing more occurs is tried first (the usual answer)."""
        return bool(self.acceptable(env)) or self.in_other_world(env, optional)

    def in_other_world(self, env: Env, optional: Mapping[str, Box]) -> bool:
        """:meth:`may_hold` without the world where nothing more occurs.

        Up to MAX_WORLD_SIGNALS optional signals the worlds are enumerated (exact); past
        that, the lifted evaluation decides (sound: it never rejects a state some world
        accepts, but may accept one that no world does; the final check catches those).
        From three signals on, the lifted evaluation first rules out hopeless states at the
        cost of one evaluation instead of up to 2^k."""
        names = [s for s in self.mentioned if s in optional]
        if not names:
            return False
        if self.parts and len(names) > 1:
            decided = self._by_parts(env, optional, len(names))
            if decided is not None:
                return decided
        if len(names) >= 3 and not self.lifted_accepts(env, {name: optional[name] for name in names}):
            return False
        if len(names) > MAX_WORLD_SIGNALS:
            return True
        # One copy of the environment, each world setting the named signals' entries in it.
        world = dict(env)
        extended = [[*env.get(name, ()), optional[name]] for name in names]
        for bits in range(1, 1 << len(names)):
            for index, name in enumerate(names):
                if bits >> index & 1:
                    world[name] = extended[index]
                elif name in env:
                    world[name] = env[name]
                else:
                    world.pop(name, None)
            if self.acceptable(world):
                return True
        return False

    def _by_parts(self, env: Env, optional: Mapping[str, Box], total: int) -> bool | None:
        """:meth:`in_other_world` one operand at a time, or None when two operands share an
        optional signal.  Exact: with disjoint signals each operand's world can be chosen on
        its own; an "or" is acceptable (true or unknown) when some operand can be, an "and"
        when every operand can be.  (Some trigger occurs, or the caller would have accepted
        the world where nothing more occurs, so the instantiation rule plays no part.)"""
        for name in self.shared:
            if name in optional:
                return None  # an optional signal named by two operands: no independence
        maybe = T | N
        parts_or = self.parts_or
        world: dict[str, Sequence[Box]] | None = None  # a copy of env, each world set in it
        for node, mentioned in self.parts:
            names = [n for n in mentioned if n in optional]
            if not names:
                possible = bool(node(env) & maybe)
            elif len(names) > MAX_WORLD_SIGNALS:
                possible = True  # too many to enumerate: sound, not exact
            else:
                if world is None:
                    world = dict(env)
                possible = _some_world(node, world, env, names, optional)
            if possible and parts_or:
                return True
            if not possible and not parts_or:
                return False
        return not parts_or

    def lifted_accepts(self, env: Env, maybe: Mapping[str, Box]) -> bool:
        """Some world of ``maybe`` may be acceptable, by the lifted evaluation (sound)."""
        if self._lifted is None:
            self._lifted = _lift(self.constraint.expr, self.duration)
        if self.triggers and not any(env.get(t) for t in self.triggers):
            return True  # the world where every maybe trigger stays absent ignores it
        return bool(self._lifted(env, maybe) & (T | N))

    def accepts_world(self, env: Env, present: Mapping[str, Box]) -> bool:
        """The one world where exactly the signals of ``present`` get one more occurrence."""
        world = dict(env)
        for name, box in present.items():
            world[name] = [*env.get(name, ()), box]
        return bool(self.acceptable(world))

    def accepting_world(self, env: Env, optional: Mapping[str, Box]) -> tuple[str, ...] | None:
        """The signals of an acceptable world other than "nothing more occurs", as few as
        possible (exactly the fewest up to MAX_WORLD_SIGNALS optional signals); None when
        no world is acceptable or the search ran out of budget."""
        names = [s for s in self.mentioned if s in optional]
        if len(names) > MAX_WORLD_SIGNALS:
            try:
                return self._search(env, optional, names)
            except _OutOfBudget:
                return None
        for bits in sorted(range(1, 1 << len(names)), key=lambda b: (bin(b).count("1"), b)):
            present = {name: optional[name] for index, name in enumerate(names) if bits >> index & 1}
            if self.accepts_world(env, present):
                return tuple(present)
        return None

    def _search(self, env: Env, optional: Mapping[str, Box], names: Sequence[str]) -> tuple[str, ...] | None:
        """Depth-first search over the worlds of ``names`` (absent first), pruned by the lifted
        evaluation: a partial choice whose lifted value cannot be acceptable is abandoned."""
        world = dict(env)
        present: list[str] = []
        budget = [WORLD_BUDGET]

        def may_accept(maybe: Mapping[str, Box]) -> bool:
            return self.lifted_accepts(world, maybe)

        def visit(index: int) -> tuple[str, ...] | None:
            budget[0] -= 1
            if budget[0] < 0:
                raise _OutOfBudget
            if index == len(names):
                return tuple(present) if present and self.acceptable(world) else None
            if not may_accept({name: optional[name] for name in names[index:]}):
                return None
            name = names[index]
            found = visit(index + 1)
            if found is not None:
                return found
            saved = world.get(name)
            world[name] = [*(saved or ()), optional[name]]
            present.append(name)
            found = visit(index + 1)
            present.pop()
            if saved is None:
                del world[name]
            else:
                world[name] = saved
            return found

        return visit(0)

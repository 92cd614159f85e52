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

import functools
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from mse.ir import model as ir
from mse.solve.greedy.closures import compile_expr, lift
from mse.solve.greedy.closures import generated as _generated
from mse.solve.greedy.masks import Box, Env, N, Node, T

#: Worlds are enumerated over at most this many optional signals per constraint; for more,
#: the lifted evaluation decides (``CompiledConstraint.in_other_world``).
MAX_WORLD_SIGNALS = 5


@functools.lru_cache(maxsize=8192)
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
            self._lifted = lift(self.constraint.expr, self.duration)
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


@functools.lru_cache(maxsize=4096)
def _compiled(constraint: ir.Constraint, duration: int | None) -> CompiledConstraint:
    return CompiledConstraint(constraint, duration if duration is not None else 0)


def compiled_constraint(constraint: ir.Constraint, duration: int) -> CompiledConstraint:
    """``constraint`` compiled for ``duration`` ms, shared by every plan that can share it: the
    duration enters a check only through ``duration`` terms (relations.known_time), so a
    constraint without one compiles once for every length (a dialogue plans a new length for
    most episodes).  The compiled checks are pure; sharing them changes no result."""
    entry = _SHARED.get(id(constraint))
    if entry is None or entry[0] is not constraint:
        uses_duration = any(
            isinstance(term, ir.DurationTime)
            for node in ir.walk(constraint.expr)
            if isinstance(node, ir.Compare)
            for term in (node.left, node.right)
        )
        if len(_SHARED) >= _SHARED_LIMIT:
            _SHARED.clear()
        entry = _SHARED[id(constraint)] = (constraint, None if uses_duration else _compiled(constraint, None))
    return entry[1] if entry[1] is not None else _compiled(constraint, duration)


# Per constraint (identity; the entry holds it, so its id is not reused): the compilation every
# length shares, or None when its checks read the duration.  Saves walking the expression and
# hashing the whole constraint (the lru_cache key) for every plan.
_SHARED: dict[int, tuple[ir.Constraint, CompiledConstraint | None]] = {}
_SHARED_LIMIT = 4096

"""The sampler's partial evaluation keeps the one semantics of mse.ir.evaluate.

* On complete timelines it is exactly the evaluator.
* On a prefix of a timeline (what the sampler sees while it walks the stamps) it never says
  "doomed" when the complete timeline satisfies the constraint (sound over-approximation).
"""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mse.ir import model as ir
from mse.ir.evaluate import evaluate_expr, is_violated
from mse.solve.greedy.closures import compile_expr
from mse.solve.greedy.masks import Box, F, N, T, compare_mask, mask_and, mask_not, mask_or, relation_mask
from mse.solve.greedy.partial import CompiledConstraint, absent_gate
from mse.solve.greedy.windows import feasible, nearest, nearest_feasible
from tests.strategies import models

DURATION = 10_000


@st.composite
def timelines(draw: st.DrawFn, model: ir.Model) -> list[tuple[str, int, int]]:
    """Occurrences of the model's signals as the sampler places them: occurrences of one
    signal never overlap (the partial evaluator relies on it; the evaluator does not care)."""
    ids = [s.id for s in model.signals]
    found: list[tuple[str, int, int]] = []
    for _ in range(draw(st.integers(0, 7))):
        name = draw(st.sampled_from(ids))
        start = draw(st.integers(0, DURATION - 1)) // 100 * 100
        stop = min(DURATION, start + draw(st.integers(1, 40)) * 100)
        if any(n == name and s < stop and start < e for n, s, e in found):
            continue
        found.append((name, start, stop))
    return sorted(found, key=lambda o: (o[1], o[0]))


def env_of(occurrences: list[tuple[str, int, int]]) -> dict[str, list[Box]]:
    env: dict[str, list[Box]] = {}
    for name, start, stop in occurrences:
        env.setdefault(name, []).append((start, start, stop, stop))
    return env


@pytest.mark.slow
@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data(), model=models(max_signals=4, max_constraints=4))
def test_complete_timelines_evaluate_exactly_as_the_evaluator(data: st.DataObject, model: ir.Model) -> None:
    occurrences = data.draw(timelines(model))
    env = env_of(occurrences)
    intervals = {k: [(b[0], b[2]) for b in v] for k, v in env.items()}
    for constraint in model.constraints:
        compiled = CompiledConstraint(constraint, DURATION)
        assert compiled.violated(env) == is_violated(constraint, intervals, DURATION)
        value = evaluate_expr(constraint.expr, intervals, DURATION)
        expected = {True: T, False: F, None: N}[value]
        assert compiled.node(env) == expected


@pytest.mark.slow
@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data(), model=models(max_signals=4, max_constraints=4))
def test_prefixes_of_satisfying_timelines_are_never_rejected(data: st.DataObject, model: ir.Model) -> None:
    occurrences = data.draw(timelines(model))
    if not occurrences:
        return
    cut = data.draw(st.integers(1, len(occurrences)))
    prefix, suffix = occurrences[:cut], occurrences[cut:]
    frontier = prefix[-1][1]
    env = env_of(prefix)
    if data.draw(st.booleans()):  # the last one is a candidate whose stop is not drawn yet
        name, start, _stop = prefix[-1]
        env[name][-1] = (start, start, start + 1, DURATION)
    optional: dict[str, Box] = {name: (frontier, DURATION - 1, frontier + 1, DURATION) for name, _, _ in suffix}
    intervals: dict[str, list[tuple[int, int]]] = {}
    for name, start, stop in occurrences:
        intervals.setdefault(name, []).append((start, stop))
    for constraint in model.constraints:
        if not is_violated(constraint, intervals, DURATION):
            assert CompiledConstraint(constraint, DURATION).may_hold(env, optional), constraint.text


def test_kleene_tables_on_value_sets() -> None:
    assert mask_not(T) == F and mask_not(F) == T and mask_not(N) == N
    assert mask_and([T, N]) == N and mask_and([F, N]) == F and mask_and([T, T]) == T
    assert mask_or([F, N]) == N and mask_or([T, N]) == T and mask_or([F, F]) == F
    assert mask_and([T | F, T]) == T | F
    assert mask_or([T | F, N]) == T | N


def test_interval_comparisons() -> None:
    assert compare_mask("<=", 1, 1, 2, 2) == T
    assert compare_mask("<=", 1, 3, 2, 2) == T | F
    assert compare_mask("=", 5, 5, 5, 5) == T
    assert compare_mask("=", 5, 5, 6, 6, 0) == F
    assert compare_mask("=", 5, 5, 6, 6, 1) == T
    assert compare_mask("=", 0, 10, 5, 5) == T | F


def _le(alo: int, ahi: int, blo: int, bhi: int) -> int:
    return (T if alo <= bhi else 0) | (F if ahi > blo else 0)


def _both(first: int, second: int) -> int:
    return (T if first & second & T else 0) | ((first | second) & F)


def _either(first: int, second: int) -> int:
    return ((first | second) & T) | (F if first & second & F else 0)


_box = st.tuples(st.integers(0, 6), st.integers(0, 3), st.integers(1, 6), st.integers(0, 3)).map(
    lambda t: (t[0], t[0] + t[1], t[0] + t[2], t[0] + t[2] + t[3])
)


@settings(max_examples=300, deadline=None)
@given(a=_box, b=_box)
def test_relation_masks_are_the_conjunctions_of_their_comparisons(a: Box, b: Box) -> None:
    """The written-out relation masks equal their definition from two interval comparisons."""
    assert relation_mask("includes", a, b) == _both(_le(a[0], a[1], b[0], b[1]), _le(b[2], b[3], a[2], a[3]))
    assert relation_mask("excludes", a, b) == _either(_le(a[2], a[3], b[0], b[1]), _le(b[2], b[3], a[0], a[1]))
    assert relation_mask("rightincludes", a, b) == _both(_le(a[0], a[1], b[2], b[3]), _le(b[2], b[3], a[2], a[3]))
    assert relation_mask("precedes", a, b) == _le(a[2], a[3], b[0], b[1])


def test_feasible_finds_single_ticks() -> None:
    assert feasible(lambda x: x == 437, 0, 999, [436, 437, 438]) == [(437, 437)]
    assert feasible(lambda x: 200 <= x <= 300, 0, 999, [199, 200, 300, 301]) == [(200, 300)]
    assert feasible(lambda x: False, 0, 10, []) == []


@settings(max_examples=300, deadline=None)
@given(
    low=st.integers(0, 50),
    width=st.integers(0, 60),
    cuts=st.lists(st.integers(-10, 120), max_size=8),
    allowed=st.lists(st.booleans(), min_size=20, max_size=20),
    target=st.integers(-5, 120),
)
def test_nearest_feasible_is_nearest_of_feasible(
    low: int, width: int, cuts: list[int], allowed: list[bool], target: int
) -> None:
    """The lazy search answers exactly what the whole window would (ties to the lower tick),
    for checks that are constant between critical points, as the sampler's are."""
    high = low + width
    edges = sorted(set(cuts))

    def check(x: int) -> bool:  # constant on every point of ``edges`` and between two of them
        rank = sum(1 for edge in edges if edge < x) * 2 + (x in edges)
        return allowed[rank % len(allowed)]

    window = feasible(check, low, high, edges)
    expected = nearest(window, target) if window else None
    assert nearest_feasible(check, low, high, edges, target) == expected


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(model=models())
def test_generated_models_are_valid_and_round_trip_through_the_ir(model: ir.Model) -> None:
    """tests/strategies.py yields models the canonical IR reads back unchanged."""
    import json

    from mse.ir.canonical import model_from_json, model_to_json

    again = model_from_json(json.loads(json.dumps(model_to_json(model))), path="generated")
    assert again.signals == model.signals
    assert [c.expr for c in again.constraints] == [c.expr for c in model.constraints]
    assert again.exclusive_modalities == model.exclusive_modalities


def _every_world(compiled: CompiledConstraint, env: dict[str, list[Box]], optional: dict[str, Box]) -> bool:
    """The definition of ``in_other_world``: some world but "nothing more" is acceptable."""
    names = [n for n in compiled.mentioned if n in optional]
    for bits in range(1, 1 << len(names)):
        present = {n: optional[n] for i, n in enumerate(names) if bits >> i & 1}
        if compiled.accepts_world(env, present):
            return True
    return False


@pytest.mark.slow
@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data(), model=models(max_signals=6, max_constraints=4))
def test_world_shortcuts_answer_as_every_world(data: st.DataObject, model: ir.Model) -> None:
    """The operand-by-operand search (a top-level or/and) and the lifted pre-check give
    exactly the enumeration's answer up to five optional signals; the lifted evaluation
    alone never rejects a state that some world accepts."""
    occurrences = data.draw(timelines(model))
    cut = data.draw(st.integers(0, len(occurrences)))
    env = env_of(occurrences[:cut])
    frontier = occurrences[cut - 1][1] if cut else 0
    ids = [s.id for s in model.signals]
    chosen = data.draw(st.lists(st.sampled_from(ids), unique=True)) if ids else []
    optional: dict[str, Box] = {name: (frontier, DURATION - 1, frontier + 1, DURATION) for name in chosen}
    exprs = [c.expr for c in model.constraints] + [
        ir.Or(tuple(ir.And((ir.Relation("includes", x, ids[0]), ir.Exists(x))) for x in ids[1:4]))
    ] if len(ids) >= 3 else [c.expr for c in model.constraints]
    for index, expr in enumerate(exprs):
        compiled = CompiledConstraint(ir.Constraint(id=f"c{index}", expr=expr), DURATION)
        if compiled.acceptable(env):
            continue
        expected = _every_world(compiled, env, optional)
        assert compiled.in_other_world(env, optional) == expected
        if expected:
            assert compiled.lifted_accepts(env, {n: optional[n] for n in compiled.mentioned if n in optional})
            assert compiled.accepting_world(env, optional) is not None


@st.composite
def _disjoint(draw: st.DrawFn) -> list[tuple[int, int]]:
    """Occurrences of one signal as the sampler places them: in start order, never overlapping."""
    found, time = [], draw(st.integers(0, 5)) * 100
    for _ in range(draw(st.integers(1, 5))):
        length = draw(st.integers(1, 20)) * 100
        if time + length > DURATION:
            break
        found.append((time, time + length))
        time += length + draw(st.integers(0, 10)) * 100
    return found or [(0, 100)]


@settings(max_examples=300, deadline=None)
@given(a=_disjoint(), b=_disjoint(), kind=st.sampled_from(["includes", "excludes", "precedes", "rightincludes"]),
       op=st.sampled_from(["<", ">", "<=", ">=", "="]), tolerance=st.sampled_from([0, 300]),
       edges=st.tuples(st.sampled_from(["start", "stop"]), st.sampled_from(["start", "stop"])))
def test_folds_over_many_occurrences_are_exact(
    a: list[tuple[int, int]], b: list[tuple[int, int]], kind: str, op: str, tolerance: int,
    edges: tuple[str, str],
) -> None:
    """Aggregates and sweeps give the evaluator's value for every combination of occurrences."""
    env = {"a": [(x, x, y, y) for x, y in a], "b": [(x, x, y, y) for x, y in b]}
    intervals = {"a": a, "b": b}
    atoms: list[ir.Expr] = [
        ir.Relation(kind, "a", "b"),  # type: ignore[arg-type]
        ir.Compare(op, ir.SignalTime("a", edges[0]), ir.SignalTime("b", edges[1], 200),  # type: ignore[arg-type]
                   tolerance if op == "=" else 0),
        ir.Compare(op, ir.SignalTime("a", edges[0]), ir.Constant(3000), tolerance if op == "=" else 0),  # type: ignore[arg-type]
    ]
    for atom in atoms:
        expected = {True: T, False: F, None: N}[evaluate_expr(atom, intervals, DURATION)]
        assert compile_expr(atom, DURATION)(env) == expected


@pytest.mark.slow
@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data(), model=models(max_signals=4, max_constraints=4))
def test_a_constraint_whose_gate_is_absent_is_acceptable(data: st.DataObject, model: ir.Model) -> None:
    """State.allows skips a constraint whose gate (partial.absent_gate) does not occur: it
    must then be acceptable (every atom unknown) whatever the checked signal's boxes."""
    env = env_of(data.draw(timelines(model)))
    for index, constraint in enumerate(model.constraints):
        compiled = CompiledConstraint(ir.Constraint(id=f"c{index}", expr=constraint.expr), DURATION)
        for name in compiled.mentioned:
            gate = absent_gate(constraint.expr, name)
            if gate is None:
                continue
            assert gate != name and gate in compiled.mentioned
            without = {n: boxes for n, boxes in env.items() if n != gate}
            assert compiled.acceptable(without)
            assert compile_expr(constraint.expr, DURATION)(without) == N


def test_absent_gate_of_pairwise_constraints() -> None:
    pair = ir.Or((ir.Relation("rightincludes", "a", "b"), ir.Relation("rightincludes", "b", "a")))
    assert absent_gate(pair, "a") == "b" and absent_gate(pair, "b") == "a"
    assert absent_gate(ir.And((ir.Exists("a"), ir.Relation("excludes", "a", "b"))), "a") is None
    three = ir.Or((ir.Relation("includes", "a", "b"), ir.Relation("includes", "c", "b")))
    assert absent_gate(three, "a") == "b" and absent_gate(three, "b") is None

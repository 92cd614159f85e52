"""The walk's speed-ups change no answer (issue 19): generated checks, folded connectives,
compiled critical points, the per-state memo of allows(), and the skipped final check."""

from __future__ import annotations

import itertools
from functools import reduce

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mse.api import load
from mse.ir import model as ir
from mse.ir.evaluate import check_schedule
from mse.solve.greedy import engine
from mse.solve.greedy.closures import compile_expr
from mse.solve.greedy.closures import generated as _generated
from mse.solve.greedy.masks import AND_TABLE, OR_TABLE, Box, mask_and, mask_or
from mse.solve.greedy.partial import HOT_CALLS, CompiledConstraint, _acceptance
from mse.solve.greedy.plan import build_plan
from mse.solve.greedy.solver import GreedySolver
from mse.solve.greedy.windows import critical_points, critical_rules, critical_values
from mse.solve.protocol import SolveRequest, get_solver
from tests.strategies import models
from tests.test_greedy_partial import DURATION, env_of, timelines


def test_n_ary_connectives_fold_over_the_binary_tables() -> None:
    for size in (3, 4, 5):
        for masks in itertools.product(range(8), repeat=size):
            assert reduce(lambda a, b: AND_TABLE[a << 3 | b], masks) == mask_and(masks)
            assert reduce(lambda a, b: OR_TABLE[a << 3 | b], masks) == mask_or(masks)


def _extra_exprs(ids: list[str]) -> list[ir.Expr]:
    """Shapes the generated models may miss: n-ary connectives, one signal twice, implies."""
    if len(ids) < 3:
        return []
    a, b, c = ids[:3]
    return [
        ir.Or(tuple(ir.And((ir.Relation("includes", x, a), ir.Exists(x))) for x in (b, c))),
        ir.And((ir.Relation("precedes", a, b), ir.Relation("excludes", b, c), ir.Not(ir.Exists(c)))),
        ir.Implies(ir.Exists(a), ir.Relation("rightincludes", a, a)),
        ir.Compare("<", ir.SignalTime(a, "start", 100), ir.SignalTime(b, "stop")),
    ]


@pytest.mark.slow
@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data(), model=models(max_signals=5, max_constraints=4))
def test_generated_checks_give_the_closures_masks(data: st.DataObject, model: ir.Model) -> None:
    """On complete and partial states (points, several occurrences, a trailing range box,
    empty lists), the generated function of a constraint gives exactly compile_expr's mask
    and _acceptance's verdict."""
    occurrences = data.draw(timelines(model))
    env: dict[str, list[Box]] = env_of(occurrences)
    ids = [s.id for s in model.signals]
    if ids and data.draw(st.booleans()):
        name = data.draw(st.sampled_from(ids))
        last = max((b[0] for b in env.get(name, [])), default=0)
        low = data.draw(st.integers(last, DURATION - 2))
        env.setdefault(name, []).append((low, DURATION - 2, low + 1, DURATION))
    if ids and data.draw(st.booleans()):
        env.setdefault(data.draw(st.sampled_from(ids)), [])  # a list left empty by a trial
    for expr in [c.expr for c in model.constraints] + _extra_exprs(ids):
        closure = compile_expr(expr, DURATION)
        assert _generated(expr, None, DURATION)(env) == closure(env)
        triggers = tuple(sorted(ir.trigger_signals(expr)))
        expected = bool(_acceptance(triggers, closure)(env))
        assert bool(_generated(expr, triggers, DURATION)(env)) == expected


def test_long_chains_and_deep_nesting_compile_to_the_closures_masks() -> None:
    """Python refuses more than 200 nested brackets: a 300-operand ``and`` (a SyntaxError
    traceback from `mse sample` before) and 190 nested ``not``/``or`` levels must compile."""
    ids = [f"s{i}" for i in range(30)]
    pairs = list(itertools.combinations(ids, 2))[:300]
    wide: ir.Expr = ir.And(tuple(ir.Or((ir.Exists(a), ir.Relation("precedes", a, b))) for a, b in pairs))
    deep: ir.Expr = ir.Exists("s0")
    for level in range(190):
        deep = ir.Not(deep) if level % 2 else ir.Or((deep, ir.Relation("includes", "s1", "s2")))
    envs = [{}, {"s0": [(0, 0, 50, 50)], "s1": [(10, 10, 20, 20)], "s2": [(12, 12, 15, 15)]},
            {name: [(3 * i, 3 * i, 3 * i + 2, 3 * i + 2)] for i, name in enumerate(ids)}]
    for expr in (wide, deep):
        closure = compile_expr(expr, DURATION)
        triggers = tuple(sorted(ir.trigger_signals(expr)))
        for env in envs:
            assert _generated(expr, None, DURATION)(env) == closure(env)
            expected = bool(_acceptance(triggers, closure)(env))
            assert bool(_generated(expr, triggers, DURATION)(env)) == expected


def test_a_check_switches_to_its_generated_function_after_hot_calls() -> None:
    expr = ir.Or((ir.Relation("precedes", "a", "b"), ir.Exists("c")))
    compiled = CompiledConstraint(ir.Constraint(id="c", expr=expr), DURATION)
    first = compiled.acceptable
    env = {"a": [(0, 0, 50, 50)], "b": [(10, 10, 20, 20)]}
    answers = {bool(compiled.acceptable(env)) for _ in range(HOT_CALLS + 2)}
    assert compiled.acceptable is not first
    assert answers == {False}
    assert compiled.acceptable({"a": [(0, 0, 5, 5)], "b": [(10, 10, 20, 20)]})


@pytest.mark.slow
@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data(), model=models(max_signals=5, max_constraints=5))
def test_compiled_critical_points_are_the_same_set(data: st.DataObject, model: ir.Model) -> None:
    plan = build_plan(model, DURATION, 1.0)
    env = env_of(data.draw(timelines(model)))
    start = data.draw(st.integers(0, DURATION - 1))
    for signal in plan.signals:
        for variable, at in (("start", None), ("stop", start)):
            rules = critical_rules(plan.edges[signal.id], signal, variable)
            expected = critical_points(plan.edges[signal.id], env, signal, variable, at)
            assert set(critical_values(rules, env, at)) == set(expected)


def _timelines(solver: object, name: str, count: int = 40) -> list[list[tuple[int, int, str]]]:
    model = load(name)
    # (the default solver without its rejection stage: the walk, whose memos these tests compare)
    found = get_solver("greedy").solve(model, SolveRequest(duration=10.0, count=count, seed=3, rejection=False)) \
        if solver is None \
        else solver.solve(model, SolveRequest(duration=10.0, count=count, seed=3))  # type: ignore[attr-defined]
    for schedule in found.schedules:
        assert not check_schedule(model, schedule)
    return [[(o.start, o.stop, o.signal) for o in s.occurrences] for s in found.schedules]


@pytest.mark.parametrize("name", ["anger", "pride", "cheerfulness"])
def test_the_final_check_of_a_settled_walk_never_fails(name: str) -> None:
    """``GreedySolver.verify`` (the evaluator's net after every walk) changes nothing."""
    checked = GreedySolver()
    checked.verify = True
    assert _timelines(GreedySolver(), name) == _timelines(checked, name)


@pytest.mark.parametrize("name", ["anger", "embarrassment", "tension"])
def test_the_memo_of_allows_changes_no_timeline(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    expected = _timelines(None, name)
    allows = engine.Attempt.allows

    def forgetful(self: engine.Attempt, signal: engine.SignalPlan, box: Box) -> bool:
        self.memo = {}  # every check evaluated afresh
        return allows(self, signal, box)

    monkeypatch.setattr(engine.Attempt, "allows", forgetful)
    assert _timelines(None, name) == expected

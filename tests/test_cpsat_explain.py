"""Explanations on generated behaviour sets: consistent with solving, and minimal."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mse.ir import model as ir
from mse.ir.evaluate import check_schedule
from mse.ir.schedule import to_ticks
from mse.solve.bounds import slot_counts
from mse.solve.cpsat.encode import build
from mse.solve.cpsat.engine import make_solver
from mse.solve.cpsat.explain import explain
from mse.solve.cpsat.solver import solve_one
from mse.solve.protocol import CpSatOptions, NoSolution, SolveRequest
from tests.strategies import models


def _feasible_without(model: ir.Model, duration: float, require: tuple[str, ...], keys: list[str]) -> bool:
    """Is there a timeline when only the rules ``keys`` are switched on?"""
    from ortools.sat.python import cp_model

    ticks = to_ticks(duration)
    counts = {s: max(1, c) for s, c in slot_counts(model, ticks, complete=True).items()}
    enc = build(model, ticks, counts, switchable=True, require=require)
    enc.cp.add_assumptions([enc.enable[k] for k in keys])
    status = make_solver(5.0).solve(enc.cp)
    assert status != cp_model.UNKNOWN
    return status in (cp_model.OPTIMAL, cp_model.FEASIBLE)


def _key(item_kind: str, item_id: str) -> str:
    prefix = {"constraint": "constraint", "duration": "duration", "occurrence rule": "modality",
              "require": "require"}[item_kind]
    return f"{prefix}:{item_id}"


@pytest.mark.slow
@settings(max_examples=80, deadline=None, suppress_health_check=list(HealthCheck))
@given(model=models(min_signals=1, max_signals=5, max_constraints=5), data=st.data())
def test_explanations_agree_with_solving_and_are_minimal(model: ir.Model, data: st.DataObject) -> None:
    ids = [s.id for s in model.signals]
    require = tuple(data.draw(st.lists(st.sampled_from(ids), unique=True, max_size=len(ids))))
    duration = data.draw(st.sampled_from([1.0, 2.0, 4.0]))
    explanation = explain(model, duration, require=require, time_limit=5.0)
    request = SolveRequest(duration=duration, require=require, time_limit=5.0)
    if explanation is None:
        schedule = solve_one(model, request, 0)
        assert check_schedule(model, schedule) == []
        return
    assert explanation.proven and explanation.minimal
    try:
        solve_one(model, request, 0)
    except NoSolution as error:
        assert error.proven
    else:
        raise AssertionError("explained as infeasible, but CP-SAT found a timeline")
    keys = [_key(item.kind, item.id) for item in explanation.items]
    assert not _feasible_without(model, duration, require, keys)
    for dropped in keys:
        assert _feasible_without(model, duration, require, [k for k in keys if k != dropped]), dropped


def test_a_verdict_without_its_explanation_when_only_the_verdict_is_needed(monkeypatch: pytest.MonkeyPatch) -> None:
    """The default solver's first pass over never-occurring signals asks CP-SAT for the verdict
    alone; the proof it shows (second pass) is explained once."""
    import mse.solve.cpsat.explain as explainer
    from mse.solve.default import DefaultSolver
    from mse.solve.protocol import get_solver

    quiet = ir.Signal("q", "face", "q", 0.5, 1.0, probability_start=0.0, probability_end=0.0)
    loud = ir.Signal("l", "head", "l", 0.5, 1.0)
    model = ir.Model("zero", (quiet, loud), (
        ir.Constraint("c1", ir.Exists("q")), ir.Constraint("c2", ir.Not(ir.Exists("q"))),
    ))
    calls: list[float] = []
    real = explainer.explain

    def counted(model: ir.Model, duration: float, **options: object) -> object:
        calls.append(duration)
        return real(model, duration, **options)  # type: ignore[arg-type]

    monkeypatch.setattr(explainer, "explain", counted)
    with pytest.raises(NoSolution) as caught:
        get_solver("cpsat").solve(model, SolveRequest(duration=5, seed=0, cpsat=CpSatOptions(explain=False)))
    assert caught.value.proven and calls == [] and caught.value.reason == "no timeline of 5 s exists"
    with pytest.raises(NoSolution) as caught:
        DefaultSolver().solve(model, SolveRequest(duration=5, seed=1))
    assert caught.value.proven and "c1" in caught.value.reason and "c2" in caught.value.reason
    assert calls == [5]

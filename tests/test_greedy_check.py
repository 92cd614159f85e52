"""The sampler's final verification stays the one semantics: the fast path of
``check_schedule`` (``is_clean``, compiled once per model) answers exactly what the full,
message-building path answers, on any schedule -- consistent or not, well formed or not."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import mse.api as api
from mse.ir import model as ir
from mse.ir.evaluate import _all_violations, _compile, check_schedule, evaluate_expr, is_clean
from mse.ir.schedule import Occurrence, Schedule, to_ticks
from mse.resources import bundled_names
from mse.solve.greedy.solver import GreedySolver
from mse.solve.protocol import SolveRequest
from tests.strategies import models

DURATION = 6_000


@st.composite
def schedules(draw: st.DrawFn, model: ir.Model) -> Schedule:
    """Occurrences on a coarse grid (so that equalities and touching edges happen), sometimes
    out of bounds, too short or too long, overlapping, or naming an unknown signal."""
    ids = [s.id for s in model.signals] + ["unknown"] * draw(st.sampled_from([0, 0, 0, 1]))
    well_formed = draw(st.booleans())  # lengths within the signal's bounds, inside the span
    found = []
    for _ in range(draw(st.integers(0, 6))):
        name = draw(st.sampled_from(ids))
        if well_formed and name in model.signal_by_id:
            signal = model.signal(name)
            shortest = to_ticks(signal.min_duration)
            longest = shortest + 2000 if signal.max_duration is None else to_ticks(signal.max_duration)
            length = draw(st.integers(max(1, shortest), max(1, shortest, longest)))
            start = draw(st.integers(0, max(0, DURATION - length) // 250)) * 250
            stop = min(DURATION, start + length)
        else:
            start = draw(st.integers(-1, DURATION // 250)) * 250
            stop = start + draw(st.integers(-1, 16)) * 250 + draw(st.sampled_from([0, 0, 0, 1, -1]))
        found.append(Occurrence(start, stop, name))
    return Schedule(DURATION, tuple(found))


@pytest.mark.slow
@settings(max_examples=250, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data(), model=models(max_signals=4, max_constraints=5))
def test_fast_path_agrees_with_the_full_check(data: st.DataObject, model: ir.Model) -> None:
    schedule = data.draw(schedules(model))
    full = _all_violations(model, schedule)
    assert is_clean(model, schedule) == (not full)
    assert check_schedule(model, schedule) == full


@pytest.mark.slow
@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data(), model=models(max_signals=4, max_constraints=5))
def test_compiled_constraints_evaluate_as_the_evaluator(data: st.DataObject, model: ir.Model) -> None:
    schedule = data.draw(schedules(model))
    intervals: dict[str, list[tuple[int, int]]] = {}
    for o in schedule.occurrences:
        intervals.setdefault(o.signal, []).append((o.start, o.stop))
    for constraint in model.constraints:
        for node in ir.walk(constraint.expr):
            assert _compile(node)(intervals, DURATION) is evaluate_expr(node, intervals, DURATION)


def test_sampled_timelines_pass_the_full_check() -> None:
    for name in bundled_names():
        model = api.load(name)
        request = SolveRequest(duration=10, seed=5, count=20)
        for schedule in GreedySolver().solve(model, request).schedules:
            assert is_clean(model, schedule)
            assert _all_violations(model, schedule) == []


def test_a_violation_still_gets_its_message() -> None:
    model = api.load("embarrassment")
    schedule = Schedule(10_000, (Occurrence(0, 2000, "tensed_smile"), Occurrence(2000, 4000, "neutral_expression")))
    assert not is_clean(model, schedule)
    kinds = {v.constraint for v in check_schedule(model, schedule)}
    assert "neutral_before_control" in kinds

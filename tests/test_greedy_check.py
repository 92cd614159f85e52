"""The sampler's final verification stays the one semantics: the fast path of
``check_schedule`` (``is_clean``, compiled once per model) answers exactly what the full,
message-building path answers, on any schedule -- consistent or not, well formed or not."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import mse.api as api
from mse.ir import model as ir
from mse.ir.evaluate import _all_violations, _compile, check_schedule, constraints_hold, evaluate_expr, is_clean
from mse.ir.relations import COMPARISONS, RELATIONS
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
    # The compiled nodes read pools (mse/ir/evaluate/fast.py): per signal, sorted, not
    # overlapping, of positive length -- what the per-signal rules leave, checked first.
    intervals: dict[str, list[tuple[int, int]]] = {}
    for signal in model.signals:
        reach = 0
        for _ in range(data.draw(st.integers(0, 4))):
            start = reach + data.draw(st.integers(0, 8)) * 250 + data.draw(st.sampled_from([0, 0, 1]))
            reach = start + data.draw(st.integers(1, 8)) * 250 + data.draw(st.sampled_from([0, 0, -1]))
            intervals.setdefault(signal.id, []).append((start, reach))
    for constraint in model.constraints:
        for node in ir.walk(constraint.expr):
            assert _compile(node)(intervals, DURATION) is evaluate_expr(node, intervals, DURATION)


@pytest.mark.slow
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data(), model=models(max_signals=4, max_constraints=5))
def test_constraints_on_pools_decide_as_the_evaluator(data: st.DataObject, model: ir.Model) -> None:
    """``constraints_hold`` (the chain's check of a move, on the pools it keeps) says a timeline
    whose per-signal rules hold violates no constraint iff the full path finds none."""
    occurrences = []
    for signal in model.signals:
        reach = 0
        for _ in range(data.draw(st.integers(0, 5 if signal.repetitive else 1))):
            start = reach + data.draw(st.integers(0, 6)) * 250
            reach = start + data.draw(st.integers(1, 6)) * 250
            occurrences.append(Occurrence(start, reach, signal.id))
    schedule = Schedule.of(2 * DURATION, occurrences)
    pools: dict[str, list[tuple[int, int]]] = {s.id: [] for s in model.signals}
    for o in schedule.occurrences:
        pools[o.signal].append((o.start, o.stop))
    violated = any(v.kind == "constraint" for v in _all_violations(model, schedule))
    assert constraints_hold(model, pools, schedule.duration) is not violated


@st.composite
def pools(draw: st.DrawFn) -> list[tuple[int, int]]:
    """A pool: sorted, not overlapping, positive lengths, often touching, on a coarse grid."""
    found, reach = [], draw(st.integers(0, 3))
    for _ in range(draw(st.integers(0, 5))):
        start = reach + draw(st.integers(0, 3))
        reach = start + draw(st.integers(1, 4))
        found.append((start, reach))
    return found


@settings(max_examples=1500, deadline=None)
@given(a=pools(), b=pools(), edges=st.tuples(st.sampled_from(["start", "stop"]), st.sampled_from(["start", "stop"])),
       offsets=st.tuples(st.integers(-3, 3), st.integers(-3, 3)), tolerance=st.integers(0, 2))
def test_every_atom_on_pools_as_every_pair(a: list[tuple[int, int]], b: list[tuple[int, int]],
                                           edges: tuple[ir.Edge, ir.Edge], offsets: tuple[int, int],
                                           tolerance: int) -> None:
    """The compiled atoms read the extremes of sorted pools (or merge them): the same truth as
    the definition over every pair of occurrences, for every relation and comparison."""
    intervals = {"x": a, "y": b}
    atoms: list[ir.Atom] = [ir.Relation(kind, left, right)  # type: ignore[arg-type]
                            for kind in RELATIONS for left, right in (("x", "y"), ("y", "x"))]
    atoms += [ir.Compare(op, ir.SignalTime("x", edges[0], offsets[0]),  # type: ignore[arg-type]
                         ir.SignalTime("y", edges[1], offsets[1]), tolerance if op == "=" else 0)
              for op in COMPARISONS]
    for atom in atoms:
        assert _compile(atom)(intervals, 100) is evaluate_expr(atom, intervals, 100), atom


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

"""CP-SAT sampling on generated sets: every timeline passes the evaluator, "no timeline" agrees
with an independent feasibility model, long timelines (rolling horizon) never dead-end, and the
control condition violates a constraint."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mse.ir import model as ir
from mse.ir.evaluate import check_schedule
from mse.ir.schedule import Schedule, to_ticks
from mse.solve.bounds import slot_counts
from mse.solve.cpsat.encode import build
from mse.solve.cpsat.engine import make_solver
from mse.solve.cpsat.solver import CpSatSolver
from mse.solve.protocol import NoSolution, SolveRequest
from tests.strategies import models

SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=list(HealthCheck))


def _exists(model: ir.Model, duration: float, *, violate: bool = False) -> bool:
    """Is there a timeline (violating a constraint with ``violate``)?  One frame, the witness
    bound of slots, no objective: an independent reference for the sampler."""
    from ortools.sat.python import cp_model

    ticks = to_ticks(duration)
    enc = build(model, ticks, slot_counts(model, ticks, complete=True), constraints=not violate,
                violate=violate)
    status = make_solver(20.0).solve(enc.cp)
    assert status != cp_model.UNKNOWN
    return status in (cp_model.OPTIMAL, cp_model.FEASIBLE)


def _check(model: ir.Model, schedule: Schedule, *, violate: bool = False) -> None:
    violations = check_schedule(model, schedule)
    if violate:
        assert any(v.kind == "constraint" for v in violations)
        violations = [v for v in violations if v.kind != "constraint"]
    assert violations == []


@pytest.mark.slow
@SETTINGS
@given(model=models(min_signals=1, max_signals=6, max_constraints=6),
       duration=st.sampled_from([1.0, 4.0, 10.0]), seed=st.integers(0, 2**20))
def test_timelines_are_consistent_and_complete(model: ir.Model, duration: float, seed: int) -> None:
    request = SolveRequest(duration=duration, seed=seed, time_limit=20.0)
    try:
        [schedule] = CpSatSolver().solve(model, request).schedules
    except NoSolution as error:
        assert error.proven
        assert not _exists(model, duration)
        return
    _check(model, schedule)


@pytest.mark.slow
@settings(max_examples=25, deadline=None, suppress_health_check=list(HealthCheck))
@given(model=models(min_signals=1, max_signals=5, max_constraints=5),
       duration=st.sampled_from([45.0, 64.5]), seed=st.integers(0, 2**20))
def test_rolling_horizon_never_dead_ends(model: ir.Model, duration: float, seed: int) -> None:
    """Long timelines are decided window by window; each window keeps the rest completable."""
    request = SolveRequest(duration=duration, seed=seed, time_limit=60.0)
    feasible = _exists(model, duration)
    try:
        [schedule] = CpSatSolver().solve(model, request).schedules
    except NoSolution as error:
        assert error.proven and not feasible
        return
    assert feasible
    _check(model, schedule)
    streamed = list(CpSatSolver().stream(model, request))
    assert Schedule.of(schedule.duration, streamed) == schedule


@pytest.mark.slow
@SETTINGS
@given(model=models(min_signals=1, max_signals=5, max_constraints=5),
       duration=st.sampled_from([4.0, 10.0, 45.0]), seed=st.integers(0, 2**20))
def test_constraint_less_violates_a_constraint(model: ir.Model, duration: float, seed: int) -> None:
    if not model.constraints:
        return
    request = SolveRequest(duration=duration, seed=seed, mode="constraint-less", time_limit=60.0)
    try:
        [schedule] = CpSatSolver().solve(model, request).schedules
    except NoSolution as error:
        assert error.proven and "violates a constraint" in str(error)
        assert not _exists(model, duration, violate=True)
        return
    _check(model, schedule, violate=True)


@pytest.mark.parametrize("mode", ["consistent", "constraint-less"])
def test_never_occurring_signals_stay_out(mode: str) -> None:
    """Both probabilities 0: absent from every default sample, unless a constraint needs it."""
    quiet = ir.Signal("quiet", "face", "x", 1.0, 2.0, 0.0, 0.0)
    loud = ir.Signal("loud", "head", "y", 1.0, 2.0, 1.0, 1.0)
    other = ir.Signal("other", "gaze", "z", 1.0, 2.0, 0.5, 0.5)
    rule = ir.Constraint("c1", ir.Relation("precedes", "loud", "other"))
    model = ir.Model("m", (quiet, loud, other), (rule,))
    for seed in range(25):
        [schedule] = CpSatSolver().solve(model, SolveRequest(duration=6.0, seed=seed, mode=mode)).schedules
        assert "quiet" not in {o.signal for o in schedule.occurrences}
    needed = ir.Model("m", (quiet, loud), (ir.Constraint("c1", ir.Exists("quiet")),))
    [schedule] = CpSatSolver().solve(needed, SolveRequest(duration=6.0, seed=1)).schedules
    assert [o.signal for o in schedule.occurrences].count("quiet") == 1


PARTNER_SET = """<expression name="partners">
  <signals>
    <signal id="a" modality="face" lexeme="a" min_duration="1" max_duration="2"
            probability_start="0.5" probability_end="0.5" repetitivity="1"/>
    <signal id="b" modality="face" lexeme="b" min_duration="1" max_duration="2"
            probability_start="0.5" probability_end="0.5" repetitivity="1"/>
    <signal id="c" modality="face" lexeme="c" min_duration="1" max_duration="2"
            probability_start="0.5" probability_end="0.5" repetitivity="1"/>
  </signals>
  <constraints>
    <constraint id="b_after_a">equal(start(b), stop(a), 0.3) and exists(a)</constraint>
    <constraint id="c_after_b">equal(start(c), stop(b), 0.3) and exists(b)</constraint>
  </constraints>
</expression>"""


@pytest.mark.parametrize("seed", range(6))
def test_windows_do_not_commit_a_partner_that_silences_a_signal(seed: int) -> None:
    """One ``b`` allows at most one ``a`` for the rest of the timeline (every pair of
    occurrences); the target, like the prior, wants ``a`` about every 3 s.  Each window weighs
    a signal's absence from the rest, so CP-SAT keeps ``a`` going instead of committing ``b``."""
    from mse.api import loads

    model = loads(PARTNER_SET, path="partners.xml")
    request = SolveRequest(duration=120.0, seed=seed, rejection=False)
    [schedule] = CpSatSolver().solve(model, request).schedules
    _check(model, schedule)
    counts = {name: sum(o.signal == name for o in schedule.occurrences) for name in "abc"}
    assert counts["a"] >= 20, counts

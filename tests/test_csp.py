"""The csp backend (python-constraint, exhaustive grid search) and its oracle role."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mse.api import load, loads
from mse.diagnostics import MseError
from mse.ir import model as ir
from mse.ir.evaluate import check_schedule
from mse.ir.schedule import to_ticks
from mse.sampling import sample
from mse.solve.cpsat.solver import enumerate_schedules, solve_one
from mse.solve.csp.solver import CspSolver, enumerate_grid
from mse.solve.protocol import CspOptions, NoSolution, Pin, SolveRequest
from mse.timeline import Timeline
from tests.strategies import models

TINY = Path(__file__).parent / "fixtures" / "solvers" / "tiny.xml"
CONFLICT = Path(__file__).parent / "fixtures" / "solvers" / "conflict.xml"

ORACLE = settings(max_examples=80, deadline=None, suppress_health_check=list(HealthCheck))


def test_csp_sample_is_on_the_grid_and_consistent() -> None:
    model = load(TINY)
    for seed in range(3):
        timeline = sample(model, 3.0, seed=seed, solver="csp", csp=CspOptions(grid=0.5))
        assert isinstance(timeline, Timeline) and timeline.solver == "csp"
        assert check_schedule(model, timeline.to_schedule()) == []
        assert all(to_ticks(s.start) % 500 == 0 and to_ticks(s.stop) % 500 == 0 for s in timeline.signals)


def test_csp_pin_require_forbid() -> None:
    model = load(TINY)
    timeline = sample(model, 3.0, seed=1, solver="csp", pinned=(Pin("look_down", 0.0, 1.0),),
                      require=("nod",), forbid=("look_away",))
    assert isinstance(timeline, Timeline)
    spans = [(s.id, s.start, s.stop) for s in timeline.signals]
    assert ("look_down", 0.0, 1.0) in spans and "nod" in {s[0] for s in spans}
    with pytest.raises(MseError, match=r"not on the 0\.5 s grid"):
        sample(model, 3.0, seed=1, solver="csp", pinned=(Pin("nod", 0.1, 1.0),))


def test_csp_refuses_large_sets() -> None:
    signals = "".join(f'<signal id="s{i}" modality="face" min_duration="1"/>' for i in range(9))
    model = loads(f'<expression name="big"><signals>{signals}</signals></expression>')
    with pytest.raises(MseError, match="at most 8 signals"):
        CspSolver().solve(model, SolveRequest(duration=4.0))


def test_csp_no_grid_timeline_is_not_a_proof() -> None:
    with pytest.raises(NoSolution) as caught:
        sample(load(CONFLICT), 2.0, seed=0, solver="csp")
    assert not caught.value.proven and "0.5 s grid" in str(caught.value)


def test_enumerations_agree_on_the_fixture() -> None:
    model = load(TINY)
    by_csp = enumerate_grid(model, 2.0, 0.5)
    by_cpsat = enumerate_schedules(model, 2.0, 0.5)
    assert len(by_csp) == len(set(by_csp)) == len(by_cpsat) == len(set(by_cpsat)) > 100
    assert set(by_csp) == set(by_cpsat)


small_models = models(min_signals=1, max_signals=4, max_constraints=4)


@pytest.mark.slow
@ORACLE
@given(model=small_models, seed=st.integers(0, 1000), data=st.data())
def test_csp_feasible_implies_cpsat_feasible(model: ir.Model, seed: int, data: st.DataObject) -> None:
    # Requiring a few signals makes the question harder than "is the empty timeline fine".
    ids = [s.id for s in model.signals]
    require = tuple(data.draw(st.lists(st.sampled_from(ids), unique=True, max_size=len(ids))))
    request = SolveRequest(duration=2.0, seed=seed, time_limit=5.0, require=require, csp=CspOptions(grid=0.5))
    try:
        grid_timeline = CspSolver().solve(model, request).schedules[0]
    except NoSolution:
        grid_timeline = None
    if grid_timeline is not None:
        assert check_schedule(model, grid_timeline) == []
    try:
        schedule = solve_one(model, request, seed)
    except NoSolution as error:
        assert grid_timeline is None, f"csp found {grid_timeline} but CP-SAT says: {error}"
        return
    assert check_schedule(model, schedule) == []


@pytest.mark.slow
@ORACLE
@given(model=small_models)
def test_grid_enumerations_agree(model: ir.Model) -> None:
    limit = 5000
    by_csp = enumerate_grid(model, 1.5, 0.5, limit=limit)
    by_cpsat = enumerate_schedules(model, 1.5, 0.5, limit=limit)
    assert len(set(by_csp)) == len(by_csp)
    if len(by_csp) == limit:  # too loose to compare exhaustively: both must reach the limit
        assert len(set(by_cpsat)) == limit
        return
    assert set(by_cpsat) == set(by_csp)
    assert len(by_cpsat) == len(by_csp)
    for schedule in by_cpsat[:50]:
        assert check_schedule(model, schedule) == []

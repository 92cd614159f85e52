"""The rejection stage (mse/solve/rejection.py): the default sampler and CP-SAT draw the target
distribution exactly where prior draws are often consistent, honour --require and --forbid,
are deterministic per seed, and fall back to the walk within a bounded cost where almost no
draw is consistent.  Every timeline is re-checked by the one evaluator."""

from __future__ import annotations

import random

import pytest

from bench.evaluation.reference import sample_reference, statistics
from mse import sampling
from mse.api import load
from mse.ir import model as ir
from mse.ir.evaluate import check_schedule
from mse.ir.prior_draw import prior_timeline
from mse.ir.schedule import Schedule, to_ticks
from mse.solve import rejection
from mse.solve.protocol import Pin, SolveRequest, get_solver
from mse.solve.rejection import Rejection, applies


def _solutions(model: ir.Model, solver: str, request: SolveRequest) -> list[tuple[Schedule, str | None]]:
    found = [(s.schedule, s.method) for s in get_solver(solver).solve(model, request).solutions]
    for schedule, _ in found:
        assert check_schedule(model, schedule) == []
    return found


def _follows_the_reference(name: str, solver: str, count: int) -> None:
    model = load(name)
    reference = statistics(model, sample_reference(model, 10, wanted=2000, seed=7, max_draws=100_000).accepted, 10)
    found = _solutions(model, solver, SolveRequest(duration=10, seed=1, count=count))
    assert {method for _, method in found} == {"rejection"}
    got = statistics(model, [schedule for schedule, _ in found], 10)
    assert abs(got.once_per_timeline - reference.once_per_timeline) <= 0.2
    for signal in model.signals:
        assert abs(got.rate[signal.id] - reference.rate[signal.id]) <= 0.1, signal.id


@pytest.mark.parametrize("solver", ["greedy", "cpsat"])
def test_samplers_follow_the_reference_on_panic_fear(solver: str) -> None:
    """Exact draws: 300 timelines (fixed seeds) within 0.2 once-only signals and 0.1 per rate of
    the reference (about 4 standard errors)."""
    _follows_the_reference("panic_fear", solver, 300)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["relief", "cheerfulness"])
@pytest.mark.parametrize("solver", ["greedy", "cpsat"])
def test_samplers_follow_the_reference_on_bundled_sets(name: str, solver: str) -> None:
    _follows_the_reference(name, solver, 300)


def test_the_timeline_json_records_rejection() -> None:
    timeline = sampling.sample(load("relief"), 10, seed=3)
    assert not isinstance(timeline, list)
    assert timeline.to_json()["method"] == "rejection"


def test_require_and_forbid_are_honoured() -> None:
    model = load("relief")
    request = SolveRequest(duration=10, seed=1, count=40, require=("relief_smile",), forbid=("gaze_away",))
    for solver in ("greedy", "cpsat"):
        found = _solutions(model, solver, request)
        assert {method for _, method in found} == {"rejection"}
        for schedule, _ in found:
            present = {o.signal for o in schedule.occurrences}
            assert "relief_smile" in present and "gaze_away" not in present


def test_not_used_where_it_cannot_draw_exactly() -> None:
    assert applies(SolveRequest())
    assert applies(SolveRequest(require=("a",), forbid=("b",)))
    assert not applies(SolveRequest(pinned=(Pin("a", 0, 1),)))
    assert not applies(SolveRequest(mode="constraint-less"))
    assert not applies(SolveRequest(objective="likely"))
    assert not applies(SolveRequest(diverse=True))
    assert not applies(SolveRequest(rejection=False))
    model = load("relief")
    [(_, method)] = _solutions(model, "greedy", SolveRequest(duration=10, seed=1, rejection=False))
    assert method == "walk"


def test_a_seed_gives_the_same_timeline_alone_in_a_count_run_and_after_a_new_pilot() -> None:
    model = load("embarrassment")
    for solver in ("greedy", "cpsat"):
        together = _solutions(model, solver, SolveRequest(duration=10, seed=5, count=6))
        rejection._BUDGETS.clear()  # the pilot is made again: it depends on the request alone
        for index, (schedule, method) in enumerate(together):
            assert _solutions(model, solver, SolveRequest(duration=10, seed=5 + index)) == [(schedule, method)]


def test_stream_gives_the_solved_timeline() -> None:
    model = load("pride")
    request = SolveRequest(duration=10, seed=4)
    for solver in ("greedy", "cpsat"):
        [(schedule, method)] = _solutions(model, solver, request)
        assert method == "rejection"
        streamed = list(get_solver(solver).stream(model, request))
        assert streamed == sorted(streamed) and Schedule.of(schedule.duration, streamed) == schedule


def test_the_pilot_does_not_depend_on_the_seed_and_counts_draws_and_occurrences() -> None:
    model = load("tension")
    first = Rejection(model, SolveRequest(duration=10, seed=1)).budget
    rejection._BUDGETS.clear()
    again = Rejection(model, SolveRequest(duration=10, seed=99)).budget
    assert first == again
    assert first.pilot_accepted == rejection.PILOT_ACCEPTED and first.draws > 0 and first.cost > 0
    # (1 - a)^K is about MISS at the low estimate of the acceptance, so at most MISS at a itself
    assert (1 - first.acceptance) ** first.draws <= rejection.MISS


def test_a_set_where_no_draw_is_consistent_goes_to_the_walk_at_a_bounded_cost() -> None:
    """anxiety at 60 s: no consistent draw in 0.8 million (bench/results/distribution.md): the
    walk, then the chain stage (mse/solve/chain.py)."""
    model = load("anxiety")
    stage = Rejection(model, SolveRequest(duration=60))
    budget = stage.budget
    assert budget.draws == 0 and budget.pilot_accepted == 0
    assert budget.pilot_draws <= rejection.PILOT_DRAWS
    assert budget.pilot_cost <= 2 * rejection.expected_cost_limit(60_000) + 2_000  # the last draw may pass it
    found = _solutions(model, "greedy", SolveRequest(duration=60, seed=1, count=3))
    assert {method for _, method in found} == {"walk+chain"}


def test_a_seed_that_misses_stops_at_its_budget(monkeypatch: pytest.MonkeyPatch) -> None:
    model = load("relief")
    stage = Rejection(model, SolveRequest(duration=10))
    draws: list[int] = []
    prior = stage.prior

    class Counted:
        def draw(self, rng: random.Random) -> Schedule:
            schedule = prior.draw(rng)
            draws.append(len(schedule.occurrences))
            return schedule

    monkeypatch.setattr(stage, "prior", Counted())
    monkeypatch.setattr(rejection, "is_consistent", lambda _model, _schedule: False)
    assert stage.sample(1) is None
    assert 0 < len(draws) <= stage.budget.draws
    assert sum(1 + n for n in draws[:-1]) < stage.budget.cost


def test_prior_draws_leave_absent_signals_out() -> None:
    model = load("relief")
    rng = random.Random(2)
    for _ in range(50):
        schedule = prior_timeline(model, to_ticks(10), rng, absent=("relief_smile",))
        assert all(o.signal != "relief_smile" for o in schedule.occurrences)

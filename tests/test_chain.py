"""The chain stage (mse/solve/chain.py): a Markov chain whose stationary law is the target (the
prior conditioned on consistency).  Its window move leaves the prior of a repetitive signal
invariant; its timelines pass the one evaluator; chained samplers and the chain reference
(bench/evaluation/reference.py) agree with rejection where rejection works; a seed gives
one timeline, by ``solve`` and by ``stream``."""

from __future__ import annotations

import math
import random
import statistics as stats

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import mse.api as api
import mse.solve.rejection as rejection
from bench.evaluation.reference import sample_chain_reference, sample_reference, statistics
from mse.ir import model as ir
from mse.ir.evaluate import check_schedule
from mse.ir.prior_draw import PriorDraw, RepetitiveDensity
from mse.ir.schedule import Schedule
from mse.solve.chain import Chain, _Run, chained
from mse.solve.protocol import NoSolution, SolveRequest, get_solver
from tests.strategies import models


def _blink(limit: int | None) -> ir.Model:
    signal = ir.Signal("blink", "face", "blink", 1.0, 3.0, probability_start=0.5, probability_end=0.1,
                       repetitivity=1, max_occurrences=limit)
    return ir.Model("blink", (signal,))


def _summary(schedules: list[Schedule]) -> tuple[float, float, float, float]:
    counts = [len(s.occurrences) for s in schedules]
    first = [s.occurrences[0].start / 1000 for s in schedules if s.occurrences]
    early = [sum(1 for o in s.occurrences if o.start < 10_000) for s in schedules]
    late = [sum(1 for o in s.occurrences if o.start >= 20_000) for s in schedules]
    return stats.mean(counts), stats.mean(first), stats.mean(early), stats.mean(late)


@pytest.mark.parametrize("limit", [None, 6])
def test_window_moves_keep_the_prior_of_a_repetitive_signal(limit: int | None) -> None:
    """A long run of window moves alone on one unconstrained repetitive signal reproduces the
    prior's own statistics (counts, counts per 10 s at both ends, first start), with and
    without a limit on occurrences that the prior reaches often."""
    model, duration = _blink(limit), 30_000
    rng = random.Random(3)
    prior = PriorDraw(model, duration)
    drawn = _summary([prior.draw(rng) for _ in range(6000)])
    chain = Chain(model, duration)
    [block] = chain.blocks
    assert block.free and not block.window  # a free block's whole redraw is exact: no windows
    block.window = chain._window(block.names)  # the windows alone, as on a constrained signal
    assert block.window
    run = _Run({"blink": []})
    kept = []
    for index in range(16_000):
        chain._windowed(block, run, rng)  # the windows alone: no whole redraw
        if index >= 1000 and index % 2 == 0:
            kept.append(Schedule.of(duration, run.state["blink"]))
    walked = _summary(kept)
    assert walked[0] == pytest.approx(drawn[0], abs=0.1)
    assert walked[1] == pytest.approx(drawn[1], abs=0.15)
    assert walked[2] == pytest.approx(drawn[2], abs=0.1)
    assert walked[3] == pytest.approx(drawn[3], abs=0.1)


def test_the_density_of_no_start_matches_the_drawn_process() -> None:
    """exp(-mass) is the probability of no start over an interval (the window term's unit)."""
    model = _blink(None)
    density = RepetitiveDensity(model.signals[0], 30_000)
    rng = random.Random(5)
    runs = [density.run(rng, 0, 2_000, None) for _ in range(20_000)]
    empty = sum(1 for r in runs if not r) / len(runs)
    assert empty == pytest.approx(math.exp(-density.mass(1, 2_000)), abs=0.01)


def _chained_samples(model: ir.Model, solver: str, duration: float, count: int,
                     monkeypatch: pytest.MonkeyPatch) -> list[Schedule]:
    # The pilot finds rejection too costly: every timeline is the chain's.
    monkeypatch.setattr(rejection, "_pilot", lambda stage: rejection.Budget(1, 0, 0, 0, 0))
    rejection._BUDGETS.clear()
    backend = get_solver(solver)
    found = []
    for seed in range(count):
        [solution] = backend.solve(model, SolveRequest(duration=duration, seed=seed)).solutions
        assert solution.method in ("walk+chain", "cpsat+chain")
        assert not check_schedule(model, solution.schedule)
        found.append(solution.schedule)
    rejection._BUDGETS.clear()
    return found


@pytest.mark.slow
@pytest.mark.parametrize("solver", ["greedy", "cpsat"])
def test_chained_samplers_and_the_chain_reference_agree_with_rejection(
    solver: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """anxiety at 10 s: 1.4 % of prior draws consistent, rejection works; the walk and CP-SAT
    alone miss it (gaze 2.4 per 10 s against 1.9).  The chain from either, and the chain
    reference, are within the bench's targets of rejection."""
    model, duration = api.load("anxiety"), 10.0
    wanted = statistics(model, sample_reference(model, duration, wanted=600, seed=1, max_draws=100_000).accepted,
                        duration)
    samples = [statistics(model, _chained_samples(model, solver, duration, 200, monkeypatch), duration)]
    if solver == "greedy":
        reference = sample_chain_reference(model, duration, wanted=300, seed=1, burn=50, thin=10)
        samples.append(statistics(model, reference.accepted, duration))
    for got in samples:
        assert got.once_per_timeline == pytest.approx(wanted.once_per_timeline, abs=0.2)
        for signal in model.signals:
            assert got.rate[signal.id] == pytest.approx(wanted.rate[signal.id], abs=0.15), signal.id


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(model=models(max_signals=5, max_constraints=5), seed=st.integers(0, 2**20),
       duration=st.sampled_from([3.0, 10.0, 40.0]))
def test_every_chained_timeline_is_consistent(model: ir.Model, seed: int, duration: float) -> None:
    request = SolveRequest(duration=duration, seed=seed, rejection=False, time_limit=5.0)
    try:
        [start] = get_solver("greedy").solve(model, request).schedules
    except NoSolution:
        return
    schedule = chained(model, start, seed)
    assert not check_schedule(model, schedule)
    assert schedule == chained(model, start, seed)


def test_a_seed_gives_one_timeline_by_solve_and_by_stream() -> None:
    """anxiety at 60 s: rejection's pilot finds no consistent draw, the chain makes every
    timeline; the stream hands out the same timeline at once."""
    model = api.load("anxiety")
    request = SolveRequest(duration=60, seed=11)
    for solver in ("greedy", "cpsat"):
        backend = get_solver(solver)
        [solution] = backend.solve(model, request).solutions
        assert solution.method == ("walk+chain" if solver == "greedy" else "cpsat+chain")
        assert not check_schedule(model, solution.schedule)
        assert backend.solve(model, request).solutions[0].schedule == solution.schedule
        streamed = list(backend.stream(model, request))
        assert Schedule.of(60_000, streamed) == solution.schedule


def test_required_signals_stay_and_forbidden_ones_never_come() -> None:
    model = api.load("anxiety")
    names = [s.id for s in model.signals if not s.repetitive]
    request = SolveRequest(duration=60, seed=2, require=(names[0],), forbid=(names[1],))
    for seed in range(3):
        [schedule] = get_solver("greedy").solve(model, SolveRequest(**{**request.__dict__, "seed": seed})).schedules
        present = {o.signal for o in schedule.occurrences}
        assert names[0] in present and names[1] not in present
        assert not check_schedule(model, schedule)

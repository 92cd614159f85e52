"""bench/evaluation/cell.py: one cell with standard errors.  Its sweep study is only worth
reading if the chain from a sampler's start, after the chain's own number of sweeps with the
seed's stream, is the sampler's timeline: checked here, and the script's table on a tiny run."""

from __future__ import annotations

import pytest

import mse.api as api
from bench.evaluation.cell import Sample, from_starts, main, mean_and_error, sampler
from mse.ir.schedule import to_ticks
from mse.solve.chain import chain_for


@pytest.mark.parametrize("solver", ["greedy", "cpsat"])
def test_the_start_and_the_chains_sweeps_are_the_samplers_timeline(solver: str) -> None:
    model, duration = api.load("anxiety"), 60.0  # rejection too costly at 60 s: both samplers chain
    sweeps = chain_for(model, to_ticks(duration)).sweeps()
    made, methods = sampler(model, duration, solver, 2)
    assert methods == f"{'walk' if solver == 'greedy' else 'cpsat'}+chain 2"
    start, chained = from_starts(model, duration, solver, 2, [0, sweeps])
    assert chained.schedules == made.schedules
    assert start.schedules != made.schedules


def test_errors_of_correlated_timelines_are_their_groups() -> None:
    """Timelines of one chain count as one draw (batch means), independent ones each."""
    values = [1.0, 1.0, 0.0, 0.0]
    _, independent = mean_and_error(Sample("x", (), (0, 1, 2, 3)), values)
    mean, grouped = mean_and_error(Sample("x", (), (0, 0, 1, 1)), values)
    assert mean == 0.5
    assert independent == pytest.approx((1 / 3) ** 0.5 / 2)  # sd sqrt(1/3) over sqrt(4)
    assert grouped == pytest.approx(0.5)  # sd of (1, 0) / sqrt(2)


def test_the_table(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["tension", "10", "--count", "3", "--solvers", "greedy", "--reference", "chain", "--chains", "2",
                 "--per-chain", "2", "--burn", "2", "--thin", "1", "--sweeps", "0", "10"]) == 0
    out = capsys.readouterr().out
    assert "| once-only / timeline | " in out and "| greedy | walk's start | walk's start + 10 sweeps |" in out
    assert "| CPU per timeline p50 / p99 (ms) |" in out

"""The CP-SAT backend: exact timelines with OR-Tools (docs/solvers.md).

``ortools`` is imported only inside functions here and in :mod:`mse.solve.cpsat.encode`,
so ``import mse`` and the greedy path never load it.  Every timeline returned has passed
:func:`mse.ir.evaluate.check_schedule`; "infeasible" is only reported as a proof
(``NoSolution(proven=True)``) when CP-SAT says INFEASIBLE with enough occurrence slots for
the witness argument of :mod:`mse.solve.bounds`; a time-out says so.
"""

from __future__ import annotations

import time
from collections.abc import Iterator, Mapping, Sequence
from typing import TYPE_CHECKING

from mse.diagnostics import Diagnostic, Span
from mse.ir import model as ir
from mse.ir.schedule import Occurrence, Schedule, to_ticks
from mse.solve.bounds import MAX_SLOTS, is_complete, slot_counts
from mse.solve.cpsat.encode import Encoding, build
from mse.solve.cpsat.engine import decode, make_solver, verified
from mse.solve.protocol import NoSolution, SolveRequest, check_request, derive_seed

if TYPE_CHECKING:
    pass

#: CP-SAT deterministic time (about seconds) spent on one --diverse timeline after the first.
DIVERSE_WORK = 0.2


class CpSatSolver:
    """Exact solving with OR-Tools CP-SAT."""

    name = "cpsat"
    supports = frozenset({"pin", "require", "forbid", "objective", "diverse", "constraint-less"})

    def solve(self, model: ir.Model, request: SolveRequest) -> list[Schedule]:
        check_request(model, request)
        schedules: list[Schedule] = []
        for index in range(max(1, request.count)):
            seed = derive_seed(request.seed, index)
            previous = schedules if request.diverse else []
            schedules.append(solve_one(model, request, seed, previous))
        return schedules

    def stream(self, model: ir.Model, request: SolveRequest) -> Iterator[Occurrence]:
        """CP-SAT decides a whole timeline at once: its occurrences in start order."""
        yield from self.solve(model, request)[0].occurrences


def _build(model: ir.Model, request: SolveRequest, counts: Mapping[str, int]) -> Encoding:
    return build(
        model, to_ticks(request.duration), counts,
        constraints=request.mode != "constraint-less",
        pins=request.pinned, require=request.require, forbid=request.forbid,
    )


def solve_one(
    model: ir.Model, request: SolveRequest, seed: int, previous: Sequence[Schedule] = ()
) -> Schedule:
    """One timeline; NoSolution (with an explanation when proven) when there is none."""
    from ortools.sat.python import cp_model

    from mse.solve.cpsat.objective import set_objective

    duration = to_ticks(request.duration)
    pins = [p.signal for p in request.pinned]
    counts = slot_counts(model, duration, complete=False, pins=pins)
    deadline = time.monotonic() + request.time_limit
    # First a light search with half the time; a time-out or an infeasible answer is
    # then retried with default parameters (and, when infeasible, enough slots for a proof).
    light = True
    while (remaining := deadline - time.monotonic()) > 0:
        enc = _build(model, request, counts)
        set_objective(enc, request.objective, seed, previous)
        solver = make_solver(remaining / 2 if light else remaining, request.workers, seed, light=light)
        if light and previous:
            # Maximising distances rarely finishes its proof: keep the best found after a
            # fixed amount of *deterministic* work, so that a seed still fixes the result.
            solver.parameters.max_deterministic_time = DIVERSE_WORK
        status = solver.solve(enc.cp)
        if status in (cp_model.OPTIMAL, cp_model.FEASIBLE):
            return verified(model, decode(enc, solver), constraints=request.mode != "constraint-less")
        if status == cp_model.INFEASIBLE:
            complete = slot_counts(model, duration, complete=True, pins=pins)
            if any(complete[s] > counts[s] for s in counts):
                counts = {s: max(counts[s], complete[s]) for s in counts}
                light = False
                continue
            if is_complete(model, duration, counts, pins):
                raise _proven_infeasible(model, request)
            message = (f"no timeline of {request.duration:g} s with at most {MAX_SLOTS} occurrences "
                       "per signal; this is not a proof that none exists")
            raise NoSolution([Diagnostic("W401", message, Span(model.path))], proven=False, reason=message)
        if not light:
            break
        light = False
    message = (f"no timeline of {request.duration:g} s found within the time limit of "
               f"{request.time_limit:g} s; this is not a proof that none exists (raise --time-limit)")
    raise NoSolution([Diagnostic("W401", message, Span(model.path))], proven=False, reason=message)


def _proven_infeasible(model: ir.Model, request: SolveRequest) -> NoSolution:
    from mse.solve.cpsat.explain import explain

    explanation = explain(
        model, request.duration, pinned=request.pinned, require=request.require,
        forbid=request.forbid, time_limit=min(request.time_limit, 5.0),
        constraints=request.mode != "constraint-less",
    )
    if explanation is None:  # the explainer ran out of time before its own proof
        message = f"no timeline of {request.duration:g} s exists"
        return NoSolution([Diagnostic("W401", message, Span(model.path))], proven=True, reason=message)
    return NoSolution(explanation.diagnostics(model), proven=True, reason=explanation.render())


def enumerate_schedules(
    model: ir.Model, duration: float, grid: float, *, limit: int = 100_000, time_limit: float = 30.0
) -> list[Schedule]:
    """Every consistent schedule whose times lie on a grid of ``grid`` seconds (tests: the
    csp oracle must find exactly as many).  Occurrence slots are the semantic limit."""
    from ortools.sat.python import cp_model

    ticks, step = to_ticks(duration), to_ticks(grid)
    enc = build(model, ticks, slot_counts(model, ticks, complete=False, step=step, exact=True), step=step)
    found: list[Schedule] = []

    class Collector(cp_model.CpSolverSolutionCallback):
        def on_solution_callback(self) -> None:
            found.append(decode(enc, self))
            if len(found) >= limit:
                self.stop_search()

    solver = make_solver(time_limit)
    solver.parameters.enumerate_all_solutions = True
    status = solver.solve(enc.cp, Collector())
    if status not in (cp_model.OPTIMAL, cp_model.FEASIBLE, cp_model.INFEASIBLE):
        raise RuntimeError("CP-SAT enumeration did not finish")
    return found

"""CP-SAT plumbing shared by the solver, the explainer and deep lint: a configured solver,
decoding an encoding's solution into a schedule, and the evaluator's re-check."""

from __future__ import annotations

from typing import TYPE_CHECKING

from mse.ir import model as ir
from mse.ir.evaluate import check_schedule
from mse.ir.schedule import Occurrence, Schedule
from mse.solve.cpsat.encode import Encoding

if TYPE_CHECKING:
    from ortools.sat.python import cp_model


def make_solver(
    time_limit: float, workers: int = 1, seed: int = 0, *, light: bool = False
) -> cp_model.CpSolver:
    """A CP-SAT solver; ``light`` skips presolve and LP relaxation, which cost more than
    they save on the small sampling models (measured in bench/cpsat.py: 3x faster)."""
    from ortools.sat.python import cp_model

    solver = cp_model.CpSolver()
    if light:
        solver.parameters.cp_model_presolve = False
        solver.parameters.linearization_level = 0
        solver.parameters.symmetry_level = 0
        solver.parameters.cp_model_probing_level = 0
    solver.parameters.max_time_in_seconds = max(0.001, float(time_limit))
    solver.parameters.num_workers = max(1, int(workers))
    solver.parameters.random_seed = seed % (2**31)
    return solver


def decode(enc: Encoding, solver: cp_model.CpSolver | cp_model.CpSolverSolutionCallback) -> Schedule:
    occurrences = [
        Occurrence(solver.value(slot.start), solver.value(slot.stop), signal_id)
        for signal_id, slots in enc.slots.items()
        for slot in slots
        if solver.boolean_value(slot.present)
    ]
    return Schedule.of(enc.duration, occurrences)


def verified(model: ir.Model, schedule: Schedule, *, constraints: bool = True) -> Schedule:
    """``schedule`` after checking it with the evaluator; an encoding bug raises."""
    violations = check_schedule(model, schedule)
    if not constraints:
        violations = [v for v in violations if v.kind != "constraint"]
    if violations:
        details = "; ".join(v.message for v in violations)
        raise RuntimeError(f"CP-SAT produced an inconsistent timeline (a bug): {details}")
    return schedule

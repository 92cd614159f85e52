"""CP-SAT plumbing shared by the solver, the explainer and deep lint: a configured solver,
decoding an encoding's solution into a schedule."""

from __future__ import annotations

from typing import TYPE_CHECKING

from mse.ir.schedule import Occurrence, Schedule
from mse.solve.cpsat.encode import Encoding

if TYPE_CHECKING:
    from ortools.sat.python import cp_model


def make_solver(
    time_limit: float, workers: int = 1, seed: int = 0, *, light: bool = False
) -> cp_model.CpSolver:
    """A CP-SAT solver; ``light`` skips presolve and LP relaxation, which cost more than
    they save on the small sampling models (measured in bench/speed/cpsat.py: 3x faster)."""
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
    # Ctrl-C is Python's: CP-SAT's own handler would end the search early and hand back
    # whatever it had (a different timeline for the seed, and the interrupt swallowed).
    solver.parameters.catch_sigint_signal = False
    return solver


def decode(enc: Encoding, solver: cp_model.CpSolver | cp_model.CpSolverSolutionCallback) -> Schedule:
    occurrences = [
        Occurrence(solver.value(slot.start), solver.value(slot.stop), signal_id)
        for signal_id, slots in enc.slots.items()
        for slot in slots
        if slot.decided and solver.boolean_value(slot.present)
    ]
    return Schedule.of(enc.duration, occurrences)

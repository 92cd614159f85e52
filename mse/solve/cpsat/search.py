"""One frame's CP-SAT searches (solver.py decides a timeline frame by frame): the solver's
parameters per stage, the deterministic work budget with its wall-clock fallback, stage 2
(positions closest to their targets) and the decoding of the decided slots.

``ortools`` is imported only inside these functions.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from mse.ir.schedule import Occurrence
from mse.solve.bounds import length_bounds
from mse.solve.cpsat.encode import Encoding, var
from mse.solve.cpsat.engine import make_solver
from mse.solve.protocol import SolveRequest

if TYPE_CHECKING:
    from mse.solve.cpsat.objective import Stages

#: CP-SAT deterministic time (about seconds) spent on a frame's positions (stage 2); the
#: other budgets are solver.py's (SAMPLE_WORK ...).
POSITION_WORK = 0.1


def hint_later(enc: Encoding, later_hints: Sequence[Occurrence]) -> None:
    """Later slots start from the previous window's plan for them."""
    from mse.solve.cpsat.objective import hint

    by_signal: dict[str, list[Occurrence]] = {}
    for occurrence in later_hints:
        by_signal.setdefault(occurrence.signal, []).append(occurrence)
    for name, slots in enc.slots.items():
        hinted = sorted(by_signal.get(name, []))
        for rank, slot in enumerate(s for s in slots if s.group == "later"):
            if rank < len(hinted):
                hint(enc, slot, hinted[rank].start, hinted[rank].stop - hinted[rank].start)
            elif rank < 2 and not later_hints:
                # No plan yet (the first window): the signal goes on repeating after the
                # window, at the end of the timeline, where the window's choices least
                # constrain it.
                low, _ = length_bounds(enc.model.signal(name), enc.duration)
                hint(enc, slot, enc.duration - (2 - rank) * low, low)
            else:
                hint(enc, slot, -1, 0)


def stage_solver(request: SolveRequest, seed: int, deadline: float, work: float, *, large: bool,
            stage: str = "options") -> Any:
    """No presolve (it costs more than the search on these models).  Large models: no LP (it
    costs more than the whole search), branching on the hint (the thinned draw) and stopping
    at the first timeline: improving it costs seconds for little.  Small ones, by ``stage``
    (measured in docs/solvers.md "Sampling at 10 s"):

    * ``options`` (the profile's one-hot option scores): no LP either; every option costs
      its own non-positive score, so the objective bound alone prunes the search, and
      without the LP each node is cheap (2x faster than with it);
    * ``positions`` (stage 2, every option fixed): presolve (it removes the fixed options),
      the LP relaxation, which bounds the distances nearly at the optimum, and a search up
      from that lower bound (the plain search closes the gap one unit per solution);
    * ``mixed`` (preferences, --diverse): the LP relaxation proves the optimum at once."""
    from ortools.sat.python import cp_model

    solver = make_solver(max(0.01, deadline - time.monotonic()), request.cpsat.workers, seed, light=True)
    if large:
        solver.parameters.search_branching = cp_model.HINT_SEARCH
        solver.parameters.stop_after_first_solution = True
    elif stage == "positions":
        solver.parameters.cp_model_presolve = True
        solver.parameters.linearization_level = 2
        solver.parameters.max_cut_rounds_at_level_zero = 1
        solver.parameters.use_objective_lb_search = True
    elif stage == "mixed":
        solver.parameters.linearization_level = 2
        solver.parameters.max_cut_rounds_at_level_zero = 1  # cuts cost more than they save here
    solver.parameters.max_deterministic_time = work
    return solver


def run_search(enc: Encoding, request: SolveRequest, seed: int, deadline: float, work: float, *,
         large: bool, stage: str) -> tuple[Any, Any]:
    """Solve with a deterministic work budget; without any timeline by then, go on to the first
    one (or a proof) within the wall-clock deadline."""
    from ortools.sat.python import cp_model

    solver = stage_solver(request, seed, deadline, work, large=large, stage=stage)
    status = solver.solve(enc.cp)
    if status != cp_model.UNKNOWN:
        return status, solver
    solver = make_solver(max(0.01, deadline - time.monotonic()), request.cpsat.workers, seed)
    solver.parameters.stop_after_first_solution = True
    return solver.solve(enc.cp), solver


def best_positions(enc: Encoding, request: SolveRequest, seed: int, deadline: float, first: Any,
               stages: Stages, *, large: bool) -> list[Occurrence]:
    """Stage 2: every option kept as stage 1 chose it, positions as close as possible to
    their targets (within POSITION_WORK); stage 1's timeline if nothing better is found."""
    from ortools.sat.python import cp_model

    found = decided_occurrences(enc, first)
    cp = enc.cp
    values = list(first.response_proto.solution)
    variables = cp.proto.variables
    for literal in stages.options:
        if isinstance(literal, cp_model.IntVar):  # fixing its domain: no constraint to add
            domain = variables[literal.index].domain
            domain[0] = domain[1] = values[literal.index]
        else:
            cp.add_bool_or([literal if first.boolean_value(literal) else ~literal])
    cp.clear_hints()  # type: ignore[no-untyped-call]
    for slots in enc.slots.values():
        for slot in slots:
            if slot.decided:
                for edge in (slot.start, slot.stop, slot.length):
                    cp.add_hint(var(edge), values[var(edge).index])
    cp.maximize(sum(stages.second(cp)))
    work = request.cpsat.work if request.cpsat.work is not None else POSITION_WORK
    solver = stage_solver(request, seed, deadline, work, large=large, stage="positions")
    status = solver.solve(cp)
    if status in (cp_model.OPTIMAL, cp_model.FEASIBLE):
        return decided_occurrences(enc, solver)
    return found


def decided_occurrences(enc: Encoding, solver: Any) -> list[Occurrence]:
    found = []
    for slots in enc.slots.values():
        for slot in slots:
            if slot.decided and solver.boolean_value(slot.present):
                start, stop = solver.value(slot.start), solver.value(slot.stop)
                found.append(Occurrence(start, stop, slot.signal))
    return found

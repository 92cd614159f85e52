"""The csp backend: exhaustive python-constraint search on a coarse grid.

Each signal is one CSP variable whose value is the tuple of its occurrences, every time a
multiple of the grid step (default 0.5 s): ``()`` when absent, else sorted
non-overlapping intervals whose lengths respect the signal's bounds, at most as many as
the semantics allows.  Constraints are checked by the one evaluator
(:mod:`mse.ir.evaluate`), which makes this backend an independent oracle for the CP-SAT
encoding.  Small sets only (MAX_SIGNALS); the search is exhaustive, so "no timeline"
means none *on this grid*, which is not a proof for the 1 ms semantics.

``constraint`` (python-constraint2) is imported only inside the functions that use it.
"""

from __future__ import annotations

import random
import time
from collections.abc import Callable, Iterator, Mapping, Sequence

from mse.diagnostics import Diagnostic, Span, argument_error
from mse.ir import model as ir
from mse.ir.evaluate import check_schedule, constraint_status
from mse.ir.schedule import Occurrence, Schedule, to_ticks
from mse.solve.bounds import length_bounds, semantic_limit
from mse.solve.protocol import CspOptions, NoSolution, Solution, SolveRequest, SolveResult, derive_seed, solve_all

#: Larger sets are refused: exhaustive search is exponential in the number of signals.
MAX_SIGNALS = 8
#: Most values (occurrence tuples) one signal may have on the grid.
MAX_DOMAIN = 20_000

Value = tuple[tuple[int, int], ...]


class _OutOfTime(Exception):
    pass


def grid_values(signal: ir.Signal, duration: int, step: int) -> list[Value]:
    """Every way ``signal`` can occur on the grid: ``()`` first, then occurrence tuples."""
    low, high = length_bounds(signal, duration)
    low = -(-low // step) * step
    high = high // step * step
    limit = semantic_limit(signal, duration, step)
    lengths = range(low, high + 1, step) if low <= high else range(0)
    values: list[Value] = [()]

    def extend(prefix: Value, earliest: int) -> None:
        if len(prefix) >= limit:
            return
        for start in range(earliest, duration, step):
            for length in lengths:
                if start + length > duration:
                    break
                value = (*prefix, (start, start + length))
                values.append(value)
                if len(values) > MAX_DOMAIN:
                    raise argument_error(f"signal {signal.id!r} has more than {MAX_DOMAIN} placements on "
                                         "this grid: use a coarser --grid or --solver cpsat")
                extend(value, start + length)

    extend((), 0)
    return values


class _Search:
    """A python-constraint problem for one model, duration and grid."""

    def __init__(self, model: ir.Model, request: SolveRequest) -> None:
        if len(model.signals) > MAX_SIGNALS:
            raise argument_error(f"the csp solver handles at most {MAX_SIGNALS} signals and {model.name!r} "
                                 f"has {len(model.signals)}: use --solver cpsat")
        self.model = model
        self.duration = to_ticks(request.duration)
        self.step = to_ticks(request.csp.grid)
        if self.step <= 0 or self.duration <= 0:
            raise argument_error("the grid step and the duration must be positive")
        self.deadline = time.monotonic() + request.time_limit
        self.constraints = request.mode != "constraint-less"
        self.domains = {s.id: grid_values(s, self.duration, self.step) for s in model.signals}
        for signal_id in request.require:
            self.domains[signal_id] = [v for v in self.domains[signal_id] if v]
        for signal_id in request.forbid:
            self.domains[signal_id] = [()]
        for pin in request.pinned:
            wanted = (to_ticks(pin.start), to_ticks(pin.stop))
            if wanted[0] % self.step or wanted[1] % self.step:
                raise argument_error(f"pin {pin.signal}@{pin.start:g}-{pin.stop:g} is not on the "
                                     f"{request.csp.grid:g} s grid")
            self.domains[pin.signal] = [v for v in self.domains[pin.signal] if wanted in v]

    def _check(self, test: Callable[..., bool]) -> Callable[..., bool]:
        def guarded(*values: Value) -> bool:
            if time.monotonic() > self.deadline:
                raise _OutOfTime
            return test(*values)

        return guarded

    def solutions(self, rng: random.Random | None) -> Iterator[Schedule]:
        from constraint import FunctionConstraint, Problem

        if self.constraints and any(
            not c.triggers and not ir.mentioned_signals(c.expr)
            and constraint_status(c, {}, self.duration) is False
            for c in self.model.constraints
        ):
            return  # a constant constraint (e.g. ``duration < 2``) that is false
        problem = Problem()
        for signal_id, values in self.domains.items():
            ordered = list(values)
            if rng is not None:
                rng.shuffle(ordered)
            if not ordered:
                return
            problem.addVariable(signal_id, ordered)
        for modality in sorted(self.model.exclusive_modalities):
            members = [s.id for s in self.model.signals if s.modality == modality]
            for index, first in enumerate(members):
                for second in members[index + 1:]:
                    problem.addConstraint(FunctionConstraint(self._check(_disjoint)), [first, second])
        if self.constraints:
            for constraint in self.model.constraints:
                names = sorted(ir.mentioned_signals(constraint.expr))
                if names:
                    problem.addConstraint(
                        FunctionConstraint(self._check(_satisfies(constraint, names, self.duration))), names)
        for solution in problem.getSolutionIter():
            yield Schedule.of(self.duration, (
                Occurrence(start, stop, signal_id)
                for signal_id, value in solution.items() for start, stop in value))


def _disjoint(first: Value, second: Value) -> bool:
    return all(a[1] <= b[0] or b[1] <= a[0] for a in first for b in second)


def _satisfies(constraint: ir.Constraint, names: Sequence[str], duration: int) -> Callable[..., bool]:
    def test(*values: Value) -> bool:
        intervals: Mapping[str, Value] = {n: v for n, v in zip(names, values, strict=True) if v}
        return constraint_status(constraint, intervals, duration) is not False

    return test


class CspSolver:
    """Exhaustive grid search with python-constraint (an oracle for small sets)."""

    name = "csp"
    supports = frozenset({"grid", "pin", "require", "forbid", "constraint-less"})

    def solutions(self, model: ir.Model, request: SolveRequest) -> Iterator[Solution]:
        from mse.solve.protocol import check_request

        check_request(model, request)
        search = _Search(model, request)
        for index in range(max(1, request.count)):
            seed = derive_seed(request.seed, index)
            rng = random.Random(seed)
            try:
                found = next(search.solutions(rng), None)
            except _OutOfTime:
                raise _no_solution(model, request, proven=False) from None
            if found is None:
                raise _no_solution(model, request, proven=True)
            violations = check_schedule(model, found)
            if request.mode == "constraint-less":
                violations = [v for v in violations if v.kind != "constraint"]
            if violations:
                raise RuntimeError(f"csp produced an inconsistent timeline (a bug): {violations}")
            yield Solution(found, seed)

    def solve(self, model: ir.Model, request: SolveRequest) -> SolveResult:
        return solve_all(self, model, request)

    def stream(self, model: ir.Model, request: SolveRequest) -> Iterator[Occurrence]:
        yield from next(self.solutions(model, request)).schedule.occurrences


def _no_solution(model: ir.Model, request: SolveRequest, *, proven: bool) -> NoSolution:
    if proven:
        message = (f"no timeline of {request.duration:g} s on the {request.csp.grid:g} s grid "
                   "(exhaustive search); a finer grid or --solver cpsat may still find one")
    else:
        message = (f"the csp search on the {request.csp.grid:g} s grid did not finish within "
                   f"{request.time_limit:g} s: use a coarser --grid or --solver cpsat")
    # Only a proof for the grid, never for the 1 ms semantics: proven stays False.
    return NoSolution([Diagnostic("W401", message, Span(model.path))], proven=False, reason=message)


def enumerate_grid(
    model: ir.Model, duration: float, grid: float, *, limit: int = 100_000, time_limit: float = 60.0
) -> list[Schedule]:
    """Every consistent schedule on the grid (up to ``limit``), in search order."""
    search = _Search(model, SolveRequest(duration=duration, time_limit=time_limit, csp=CspOptions(grid)))
    found: list[Schedule] = []
    for schedule in search.solutions(None):
        found.append(schedule)
        if len(found) >= limit:
            break
    return found

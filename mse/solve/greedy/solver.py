"""The paper's greedy stochastic sampler (§4.3) behind the solver protocol: ``--solver greedy``.

A walk ends only when nothing is owed, which its exact checks of the placed points establish
(``GreedySolver.verify`` re-checks with :func:`mse.ir.evaluate.check_schedule`).  A walk that
paints itself into a corner backtracks to its last checkpoint (walk.py; the same seeded random
stream continues, so the result depends on the seed alone), at most ``request.greedy.max_restarts``
times without getting further, then :class:`NoSolution` (not a proof) names the constraints
that were never met.  ``mode="constraint-less"`` is the paper's control
condition (§5.3): same signals, durations and probability profiles, constraints ignored, and
every returned timeline violates at least one constraint.  Imports nothing heavy.
"""

from __future__ import annotations

import random
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass

from mse.diagnostics import Diagnostic, Span, argument_error
from mse.ir import model as ir
from mse.ir.evaluate import check_schedule
from mse.ir.schedule import Occurrence, Schedule, to_ticks
from mse.solve.greedy.debts import Doomed
from mse.solve.greedy.engine import Attempt
from mse.solve.greedy.plan import DEFAULT_SLOT, Plan, plan_for
from mse.solve.greedy.walk import OutOfBudget, walk, walk_steps
from mse.solve.protocol import NoSolution, Solution, SolveRequest, SolveResult, derive_seed, solve_all


def validate(model: ir.Model, request: SolveRequest) -> None:
    if not request.duration > 0 or to_ticks(request.duration) < 1:
        raise argument_error(f"duration must be a positive number of seconds, not {request.duration!r}")
    options = request.greedy
    if options.slot is not None and not options.slot > 0:
        raise argument_error(f"slot must be a positive number of seconds, not {options.slot!r}")
    if request.count < 1:
        raise argument_error(f"count must be at least 1, not {request.count}")
    if options.max_restarts < 0:
        raise argument_error(f"max_restarts must be at least 0, not {options.max_restarts}")
    if request.mode not in ("consistent", "constraint-less"):
        raise argument_error(f"unknown mode {request.mode!r} (known: consistent, constraint-less)")
    unknown = sorted({*request.require, *request.forbid} - set(model.signal_by_id))
    if unknown:
        known = ", ".join(s.id for s in model.signals)
        raise argument_error(
            f"unknown signal(s) {', '.join(unknown)} in require/forbid for {model.name!r} (known: {known})")
    both = sorted(set(request.require) & set(request.forbid))
    if both:
        raise argument_error(f"signal(s) {', '.join(both)} both required and forbidden")
    if request.mode == "constraint-less" and not model.constraints:
        raise argument_error(
            f"{model.name!r} has no constraints, so no timeline can violate one "
            "(--mode constraint-less needs a behaviour set with constraints)"
        )


@dataclass
class Tally:
    """Walks started and backtracks taken, counted by :meth:`GreedySolver.one` (also when it
    fails) for the caller that made it."""

    attempts: int = 0
    restarts: int = 0


class GreedySolver:
    """The walk alone (``name = "walk"``): streaming, seeded, constraint-less control mode.

    ``mse sample`` and ``api.sample`` use :class:`mse.solve.default.DefaultSolver` (name
    ``greedy``), which runs this walk and falls back to a complete solver when it fails."""

    name = "walk"
    supports = frozenset({"stream", "constraint-less", "require", "forbid"})
    #: Re-check every timeline of the walk with :func:`mse.ir.evaluate.check_schedule` before
    #: returning it (a walk that fails it walks again).  Off by default: the walk only ends
    #: when nothing is owed, which its exact checks of the placed points establish (the tests
    #: re-check every output with the evaluator, and turn this on to exercise the net).
    verify = False

    def solutions(self, model: ir.Model, request: SolveRequest) -> Iterator[Solution]:
        validate(model, request)
        for index in range(request.count):
            seed, tally = derive_seed(request.seed, index), Tally()
            yield Solution(self.one(model, request, seed, tally), seed, None, tally.attempts, tally.restarts)

    def solve(self, model: ir.Model, request: SolveRequest) -> SolveResult:
        return solve_all(self, model, request)

    def stream(self, model: ir.Model, request: SolveRequest) -> Iterator[Occurrence]:
        """The occurrences of one timeline in start order, each batch handed out as soon as
        the walk reaches a checkpoint: the occurrences before it are, alone, a consistent
        timeline, so no later failure takes them back (the walk never backtracks past it)."""
        validate(model, request)
        seed = derive_seed(request.seed, 0)
        if request.mode == "constraint-less":
            yield from sorted(self.one(model, request, seed).occurrences)
            return
        _, attempt = self._attempt(model, request, seed)
        try:
            steps = walk_steps(attempt, request.greedy.max_restarts, stream=True)
            while True:
                try:
                    batch = next(steps)
                except StopIteration as done:
                    yield from sorted(done.value)
                    return
                yield from sorted(batch)
        except (Doomed, OutOfBudget) as failure:
            raise self._failure(model, request, seed, _reasons(failure)) from None

    # -- one timeline -----------------------------------------------------------------------------
    def _attempt(self, model: ir.Model, request: SolveRequest, seed: int) -> tuple[Plan, Attempt]:
        duration = to_ticks(request.duration)
        slot = request.greedy.slot if request.greedy.slot is not None else DEFAULT_SLOT
        free = request.mode == "constraint-less"
        plan = plan_for(model, duration, slot, with_constraints=not free, cache=request.greedy.cache_plan)
        attempt = Attempt(plan, random.Random(seed), frozenset(request.forbid), frozenset(request.require))
        return plan, attempt

    def one(self, model: ir.Model, request: SolveRequest, seed: int, tally: Tally | None = None) -> Schedule:
        """One timeline of the walk for ``seed``; :class:`NoSolution` (not a proof) when the
        walk fails ``request.greedy.max_restarts`` times without getting further.  Its walks
        and backtracks are added to ``tally``."""
        tally = tally if tally is not None else Tally()
        max_restarts = request.greedy.max_restarts
        plan, attempt = self._attempt(model, request, seed)
        free = request.mode == "constraint-less"
        rng = attempt.rng
        forbid, require = attempt.forbid, attempt.require
        unmet: Counter[str] = Counter()
        # The walk backtracks by itself; a new walk starts only in constraint-less mode (a prior
        # sample that violates nothing) or after a sampler bug caught by the final check.
        for fresh in range(max_restarts + 1 if free else 3):
            if fresh:
                attempt = Attempt(plan, rng, forbid, require)
            tally.attempts += 1
            backtracks = [0]
            try:
                occurrences = walk(attempt, max_restarts, backtracks)
            except (Doomed, OutOfBudget) as failure:
                tally.restarts += backtracks[0]
                unmet.update(_reasons(failure))
                break
            tally.restarts += backtracks[0] + (fresh > 0)
            schedule = Schedule.of(plan.duration, occurrences)
            if not free and not self.verify:
                # The walk ended settled: every constraint was re-evaluated, exactly on the
                # placed points, after each placement that could change its verdict, and none
                # is owed; occurrence rules hold by construction (docs/sampler.md, "Speed").
                return schedule  # the usual case
            violations = check_schedule(model, schedule)
            if not violations and not free:
                return schedule
            structural = [v for v in violations if v.kind != "constraint"]
            if structural:  # built correctly by construction: this would be a sampler bug
                unmet.update(v.kind for v in structural)
                continue
            if free:
                if violations:
                    return schedule
                unmet["(every constraint held)"] += 1
                continue
            unmet.update(v.constraint or v.kind for v in violations)
        raise self._failure(model, request, seed, unmet)

    def _failure(self, model: ir.Model, request: SolveRequest, seed: int, unmet: Counter[str]) -> NoSolution:
        what = "timeline violating a constraint" if request.mode == "constraint-less" else "consistent timeline"
        head = (
            f"the greedy walk found no {what} of {request.duration:g} s for {model.name!r} "
            f"(seed {seed}, {request.greedy.max_restarts} backtracks without progress)"
        )
        by_id = {c.id: c for c in model.constraints}
        diagnostics: list[Diagnostic] = []
        reasons = []
        for name, times in unmet.most_common():
            reasons.append(f"{name} ({times}x)")
            constraint = by_id.get(name)
            if constraint is not None:
                text = constraint.text or constraint.id
                message = f"{head}: constraint {name!r} could not be met ({times}x): {text}"
                diagnostics.append(Diagnostic("W401", message, constraint.span))
        summary = f"{head}; unmet: {', '.join(reasons) or 'nothing recorded'}"
        if not diagnostics:
            diagnostics.append(Diagnostic("W401", summary, Span(model.path)))
        hint = " (--solver cpsat can prove whether a timeline exists)"
        return NoSolution(diagnostics, proven=False, reason=summary + hint)


def _reasons(failure: Exception) -> Counter[str]:
    if isinstance(failure, OutOfBudget):
        return failure.unmet
    return Counter([str(failure)])


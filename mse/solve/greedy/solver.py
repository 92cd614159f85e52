"""The paper's greedy stochastic sampler (§4.3) behind the solver protocol: ``--solver greedy``.

Every returned schedule is verified with :func:`mse.ir.evaluate.check_schedule`; an attempt
that fails is restarted (the same seeded random stream continues, so the result depends on the
seed alone), at most ``request.max_restarts`` times, then :class:`NoSolution` names the
constraints that were never met.  ``mode="constraint-less"`` is the paper's control
condition (§5.3): same signals, durations and probability profiles, constraints ignored, and
every returned timeline violates at least one constraint.  Imports nothing heavy.
"""

from __future__ import annotations

import random
from collections import Counter
from collections.abc import Iterator

from mse.diagnostics import Diagnostic, MseError, Span
from mse.ir import model as ir
from mse.ir.evaluate import check_schedule
from mse.ir.schedule import Occurrence, Schedule, to_ticks
from mse.solve.greedy.engine import Attempt, Doomed
from mse.solve.greedy.plan import DEFAULT_SLOT, plan_for
from mse.solve.greedy.walk import walk
from mse.solve.protocol import NoSolution, SolveRequest, derive_seed


def _error(message: str) -> MseError:
    return MseError([Diagnostic("E100", message, Span("<arguments>"))])


def _validate(model: ir.Model, request: SolveRequest) -> None:
    if not request.duration > 0 or to_ticks(request.duration) < 1:
        raise _error(f"duration must be a positive number of seconds, not {request.duration!r}")
    if request.slot is not None and not request.slot > 0:
        raise _error(f"slot must be a positive number of seconds, not {request.slot!r}")
    if request.count < 1:
        raise _error(f"count must be at least 1, not {request.count}")
    if request.max_restarts < 0:
        raise _error(f"max_restarts must be at least 0, not {request.max_restarts}")
    if request.mode not in ("consistent", "constraint-less"):
        raise _error(f"unknown mode {request.mode!r} (known: consistent, constraint-less)")
    unknown = sorted({*request.require, *request.forbid} - set(model.signal_by_id))
    if unknown:
        raise _error(f"unknown signal(s) {', '.join(unknown)} in require/forbid for {model.name!r}")
    both = sorted(set(request.require) & set(request.forbid))
    if both:
        raise _error(f"signal(s) {', '.join(both)} both required and forbidden")
    if request.mode == "constraint-less" and not model.constraints:
        raise _error(
            f"{model.name!r} has no constraints, so no timeline can violate one "
            "(--mode constraint-less needs a behaviour set with constraints)"
        )


class GreedySolver:
    """``name = "greedy"``: streaming, seeded, constraint-less control mode."""

    name = "greedy"
    supports = frozenset({"stream", "constraint-less", "require", "forbid"})

    def __init__(self) -> None:
        #: Attempts and restarts of the last :meth:`solve` (the bench reads them).
        self.attempts = 0
        self.restarts = 0

    def solve(self, model: ir.Model, request: SolveRequest) -> list[Schedule]:
        _validate(model, request)
        self.attempts = self.restarts = 0
        return [self._one(model, request, derive_seed(request.seed, i)) for i in range(request.count)]

    def stream(self, model: ir.Model, request: SolveRequest) -> Iterator[Occurrence]:
        """The occurrences of one timeline, in the order the sampler decided them (start
        order).  The whole timeline is decided and verified before the first one is yielded
        (a few hundred microseconds): a consumer can never be handed an occurrence that a
        restart would take back."""
        _validate(model, request)
        schedule = self._one(model, request, derive_seed(request.seed, 0))
        yield from sorted(schedule.occurrences)

    # -- one timeline -----------------------------------------------------------------------------
    def _one(self, model: ir.Model, request: SolveRequest, seed: int) -> Schedule:
        duration = to_ticks(request.duration)
        slot = request.slot if request.slot is not None else DEFAULT_SLOT
        free = request.mode == "constraint-less"
        plan = plan_for(model, duration, slot, with_constraints=not free)
        rng = random.Random(seed)
        forbid, require = frozenset(request.forbid), frozenset(request.require)
        unmet: Counter[str] = Counter()
        for attempt in range(request.max_restarts + 1):
            self.attempts += 1
            self.restarts += attempt > 0
            try:
                occurrences = walk(Attempt(plan, rng, forbid, require))
            except Doomed as doomed:
                unmet[str(doomed)] += 1
                continue
            schedule = Schedule.of(duration, occurrences)
            violations = check_schedule(model, schedule)
            if not violations and not require and not free:
                return schedule  # the usual case, decided as below without the bookkeeping
            structural = [v for v in violations if v.kind != "constraint"]
            # The engine builds structure correctly by construction; a structural violation
            # would be a sampler bug, and is never returned either.
            if structural:
                unmet.update(v.kind for v in structural)
                continue
            missing = sorted(require - {o.signal for o in occurrences})
            if missing:
                unmet.update(f"require {name}" for name in missing)
                continue
            if free:
                if violations:
                    return schedule
                unmet["(every constraint held)"] += 1
                continue
            if not violations:
                return schedule
            unmet.update(v.constraint or v.kind for v in violations)
        raise self._failure(model, request, seed, unmet)

    def _failure(self, model: ir.Model, request: SolveRequest, seed: int, unmet: Counter[str]) -> NoSolution:
        attempts = request.max_restarts + 1
        what = "timeline violating a constraint" if request.mode == "constraint-less" else "consistent timeline"
        head = (
            f"greedy sampler found no {what} of {request.duration:g} s for {model.name!r} "
            f"in {attempts} attempt(s) (seed {seed})"
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
        hint = " (try --solver cpsat, which can prove whether a timeline exists)"
        return NoSolution(diagnostics, proven=False, reason=summary + hint)

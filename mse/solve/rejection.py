"""The rejection stage: exact samples of the target where they are cheap (docs/sampler.md,
"Rejection").

The target of every sampler is the prior conditioned on consistency (docs/semantics.md,
"Probabilities").  Drawing the prior (:func:`mse.ir.prior_draw.prior_timeline`) and keeping
the first draw the one evaluator accepts (:func:`mse.ir.evaluate.is_consistent`, which stops at
the first violation) *is* a sample of it.  On most sets a tenth or more of the draws are
consistent and a draw costs a fraction of a millisecond, so this is as fast as the walk and
exact; where almost no draw is consistent it would never end, so its budget is set per request
from a *pilot*:

* the pilot draws, from a fixed seed (so it does not depend on the request's seed), until
  PILOT_ACCEPTED draws are consistent, PILOT_DRAWS are drawn or twice the cost limit below is
  drawn (once the limit, while none is consistent), and estimates the acceptance ``a`` and
  the cost of a draw (in drawn occurrences, which is what a draw and its check cost: about
  10-45 microseconds each);
* when the pilot accepted nothing, or the expected cost of one accepted draw (cost / ``a``)
  exceeds :func:`expected_cost_limit` (3,000 occurrences plus 5 per second of timeline), the
  stage is not used for the request;
* otherwise each seed draws at most ``K = ceil(ln(1 / MISS) / a_low)`` timelines and at most
  ``2 K`` times the pilot's mean cost in occurrences (and MAX_SEED_COST), ``a_low`` being a
  low estimate of the acceptance (``(accepted - 2 sqrt(accepted)) / draws``, at least
  ``0.5 / draws``: a pilot of a few accepted draws often overestimates it), so that
  ``(1 - a)^K`` is at most about MISS: the first consistent draw is the timeline, and when
  none is, the caller goes on (the walk).
  A generous K costs little: a seed stops at its first consistent draw, about ``1 / a`` draws.

Everything is counted in draws and occurrences, never in wall time, so a seed gives the same
timeline on any machine, alone or inside a ``--count`` run (each seed draws from its own
``random.Random(f"rejection/{seed}")``).  A timeline accepted here is an exact sample; one the
stage misses (a share MISS of seeds where it is used) comes from the next stage, so the
mixture is the target up to that share.

The stage honours ``--forbid`` (a forbidden signal is not drawn: under the prior signals are
independent, so that is the prior conditioned on its absence) and ``--require`` (a draw
without the signal is rejected).  It is not used for what it cannot draw exactly: pinned
signals, an objective, ``--diverse`` timelines and the constraint-less mode; nor where the
request turns it off (``SolveRequest.rejection``: a dialogue's episodes) (:func:`applies`).
"""

from __future__ import annotations

import math
import random
import weakref
from dataclasses import dataclass

from mse.ir import model as ir
from mse.ir.evaluate import is_consistent
from mse.ir.prior_draw import PriorDraw
from mse.ir.profile import never_occurs
from mse.ir.schedule import TICKS_PER_SECOND, Schedule, to_ticks
from mse.solve.protocol import SolveRequest

#: The pilot stops at this many consistent draws (the acceptance then within about 30 %) ...
PILOT_ACCEPTED = 10
#: ... or after this many draws, or after drawing twice the largest expected cost below.
PILOT_DRAWS = 200
#: The pilot's seed: one per request, whatever the request's seed.
PILOT_SEED = "rejection/pilot"
#: Share of seeds the stage may miss where it is used ((1 - a)^K).
MISS = 1e-3
#: The stage is used when one accepted draw costs at most EXPECTED_COST + EXPECTED_COST_PER_SECOND
#: x the duration in seconds drawn occurrences on average (cost per draw / acceptance).  A drawn
#: and checked occurrence costs 10-45 us; a walk 0.25-2 ms at 10 s and about 0.1 ms per second
#: of timeline at an hour (150-390 ms): 3,050 occurrences at 10 s (30-140 ms, reached only where
#: 1-3 % of the draws are consistent, as anxiety's, where the walk misses a signal's rate by
#: 0.39), 21,000 at an hour (0.2-0.9 s, about one walk).
EXPECTED_COST = 3_000
EXPECTED_COST_PER_SECOND = 5.0
#: Occurrences one seed draws at most (1.5-4 s; reached by about MISS of the seeds).
MAX_SEED_COST = 100_000


def expected_cost_limit(duration: int) -> float:
    """The largest expected cost (drawn occurrences) of one accepted draw for which the stage
    is used, for a timeline of ``duration`` ticks."""
    return EXPECTED_COST + EXPECTED_COST_PER_SECOND * duration / TICKS_PER_SECOND


@dataclass(frozen=True, slots=True)
class Budget:
    """What the pilot found for one request, and the per-seed budget it implies."""

    pilot_draws: int
    pilot_accepted: int
    pilot_cost: int  # occurrences drawn by the pilot
    #: Draws per seed (0: the stage is not used for this request).
    draws: int
    #: Occurrences drawn per seed at most.
    cost: int

    @property
    def acceptance(self) -> float:
        return self.pilot_accepted / self.pilot_draws if self.pilot_draws else 0.0


def applies(request: SolveRequest) -> bool:
    """The request asks for the stage and the stage draws its target exactly: consistent mode,
    nothing pinned, no objective, not diverse (``require`` and ``forbid`` are honoured)."""
    return (request.rejection and request.mode == "consistent" and not request.pinned
            and request.objective is None and not request.diverse)


class Rejection:
    """The stage for one model and one request (whatever its seed)."""

    def __init__(self, model: ir.Model, request: SolveRequest) -> None:
        self.model = model
        self.duration = to_ticks(request.duration)
        # Never-occurring signals are never drawn: leaving them out of ``absent`` changes nothing
        # but lets requests that differ only by forbidding them share a pilot.
        self.absent = frozenset(name for name in request.forbid if not never_occurs(model.signal(name)))
        self.require = tuple(sorted(set(request.require)))
        self.prior = PriorDraw(model, self.duration, self.absent)
        self.budget = _budget(self)

    def _draw(self, rng: random.Random) -> tuple[Schedule, bool]:
        schedule = self.prior.draw(rng)
        if self.require:
            present = {o.signal for o in schedule.occurrences}
            if any(name not in present for name in self.require):
                return schedule, False
        return schedule, is_consistent(self.model, schedule)

    def sample(self, seed: int) -> Schedule | None:
        """The first consistent draw of ``seed`` within the budget; None when there is none."""
        budget = self.budget
        if not budget.draws:
            return None
        rng = random.Random(f"rejection/{seed}")
        spent = 0
        for _ in range(budget.draws):
            schedule, accepted = self._draw(rng)
            if accepted:
                return schedule
            spent += 1 + len(schedule.occurrences)
            if spent >= budget.cost:
                return None
        return None


def _pilot(stage: Rejection) -> Budget:
    rng = random.Random(PILOT_SEED)
    limit = expected_cost_limit(stage.duration)
    draws = accepted = cost = 0
    # Nothing accepted after the limit's worth of draws: the stage would cost more than the limit.
    while draws < PILOT_DRAWS and accepted < PILOT_ACCEPTED and cost < (2 if accepted else 1) * limit:
        schedule, ok = stage._draw(rng)
        draws += 1
        accepted += ok
        cost += 1 + len(schedule.occurrences)
    if not accepted:
        return Budget(draws, accepted, cost, 0, 0)
    acceptance, per_draw = accepted / draws, cost / draws
    if per_draw / acceptance > limit:
        return Budget(draws, accepted, cost, 0, 0)
    low = max(accepted - 2 * math.sqrt(accepted), 0.5) / draws
    most = math.ceil(math.log(MISS) / math.log1p(-low))
    return Budget(draws, accepted, cost, most, min(MAX_SEED_COST, math.ceil(2 * most * per_draw)))


# The pilot of a request depends on the model, the duration and what it requires and forbids:
# kept per model object (identity, as the evaluator's compiled checkers), a few per model.
_BUDGETS: dict[int, tuple[weakref.ref[ir.Model], dict[tuple[object, ...], Budget]]] = {}
_BUDGETS_LIMIT = 256
_PER_MODEL_LIMIT = 64


def _budget(stage: Rejection) -> Budget:
    model = stage.model
    entry = _BUDGETS.get(id(model))
    if entry is None or entry[0]() is not model:
        if len(_BUDGETS) >= _BUDGETS_LIMIT:
            _BUDGETS.clear()
        entry = _BUDGETS[id(model)] = (weakref.ref(model), {})
    known = entry[1]
    key = (stage.duration, stage.require, stage.absent)
    budget = known.get(key)
    if budget is None:
        if len(known) >= _PER_MODEL_LIMIT:
            known.clear()
        budget = known[key] = _pilot(stage)
    return budget

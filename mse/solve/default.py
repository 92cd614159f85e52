"""The default solver (``--solver greedy``): exact draws, the paper's walk, then a complete fallback.

``mse sample`` must return a timeline whenever one exists, and say so with a proof when none
does.  The composition, per timeline (seed ``S + i``):

1. **rejection** — prior draws, the first consistent one wins (:mod:`mse.solve.rejection`): an
   exact sample of the target distribution, used where the request's pilot says it is cheap
   (plain requests: nothing pinned; ``--require`` and ``--forbid`` are honoured);
2. **walk** — the greedy walk of :mod:`mse.solve.greedy` (docs/sampler.md), which backtracks
   to its checkpoints by itself (the repair step), where the stage is not used or misses;
   on plain requests (those the stage applies to) its timeline, or the fallback's, then starts
   the **chain** (:mod:`mse.solve.chain`), whose stationary law is the target;
3. **cpsat** — when the walk gives up (or the request pins signals, which the walk does not
   place), CP-SAT with its default objective, which follows the same probability profile
   (:mod:`mse.ir.profile`), finds a timeline if one exists;
4. **proof** — when CP-SAT proves that none exists, its minimal explanation (file:line of
   every rule in the conflict) is the answer (``NoSolution(proven=True)``).

Signals whose probabilities are both 0 never occur (mse.ir.profile.never_occurs) unless the
request requires or pins them, or no timeline exists without them (a constraint demands
them): they are forbidden in a first pass, allowed in a second one only when the first is
proven infeasible (the rejection stage never draws them).

Each solution records how it was made (:attr:`mse.solve.protocol.Solution.method`:
``rejection``, ``walk``, ``cpsat``, ``walk+chain`` or ``cpsat+chain``; the timeline JSON's
``"method"``) and the walk's attempts
and backtracks.  :meth:`DefaultSolver.stream` gives the same timeline as a solve of the seed:
the stage's (or the chain's) timeline at once, or the walk's stream (the first occurrences long
before the end); a dialogue's episodes turn both off (``SolveRequest.rejection``) to keep the
walk's latency.  CP-SAT is reached only through
:func:`mse.solve.protocol.get_solver` and imported only when the walk fails, so sampling a
set the walk solves never loads ortools.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace

from mse.ir import model as ir
from mse.ir.profile import never_occurs
from mse.ir.schedule import Occurrence, Schedule
from mse.solve.chain import chained
from mse.solve.greedy.solver import GreedySolver, Tally, validate
from mse.solve.protocol import (
    NoSolution,
    Solution,
    SolveRequest,
    SolveResult,
    check_request,
    derive_seed,
    get_solver,
    solve_all,
)
from mse.solve.rejection import Rejection, applies

#: Name of the complete fallback solver, as recorded in ``"method"``.
FALLBACK = "cpsat"


class DefaultSolver:
    """``name = "greedy"``: rejection → walk → (backtracking) → CP-SAT → proof.  It reports nothing
    through attributes: what one solve learns of its request lives in a :class:`_Run` for
    that solve alone, and each :class:`Solution` says how it was made."""

    name = "greedy"
    supports = frozenset({"stream", "constraint-less", "require", "forbid", "pin"})

    def __init__(self) -> None:
        self.walker = GreedySolver()
        # The last request's checked setup, for a loop of one solve per seed (``mse.sample``
        # in a loop): a cache of what does not depend on the seed, never a report.
        self._setup: _Setup | None = None

    def _run(self, model: ir.Model, request: SolveRequest) -> _Run:
        setup = self._setup
        if setup is None or setup.model is not model or not _same_but_seed(setup.request, request):
            setup = self._setup = _Setup(model, request)
        return _Run(self.walker, setup, request)

    def solutions(self, model: ir.Model, request: SolveRequest) -> Iterator[Solution]:
        run = self._run(model, request)
        for index in range(request.count):
            yield run.one(derive_seed(request.seed, index))

    def solve(self, model: ir.Model, request: SolveRequest) -> SolveResult:
        return solve_all(self, model, request)

    def stream(self, model: ir.Model, request: SolveRequest) -> Iterator[Occurrence]:
        """The timeline :meth:`solutions` gives for the seed, as soon as each part is decided:
        the rejection stage's draw at once (it decides a whole timeline), else the walk's
        stream (each batch handed out at a checkpoint, docs/sampler.md); when the walk gives up
        before its first checkpoint, the fallback's timeline at once."""
        run = self._run(model, request)
        if applies(request):  # the rejection stage's draw, or the chain's: a whole timeline at once
            yield from sorted(run.one(derive_seed(request.seed, 0)).schedule.occurrences)
            return
        if not request.pinned:
            streamed = False
            try:
                for occurrence in self.walker.stream(model, run.first):
                    streamed = True
                    yield occurrence
                return
            except NoSolution:
                if streamed:  # cannot happen: the walk ends at its last commit instead
                    raise
        yield from sorted(run.one(derive_seed(request.seed, 0), walk=False).schedule.occurrences)


def _same_but_seed(known: SolveRequest, request: SolveRequest) -> bool:
    """``request`` asks what ``known`` asks, but perhaps for another seed."""
    if known is request:
        return True
    fields_of = request.__dict__  # (a frozen dataclass without slots: one dict compare)
    return {**known.__dict__, "seed": fields_of["seed"]} == fields_of


class _Setup:
    """What a request implies whatever its seed: it is valid, its never-occurring signals,
    the walk's first request and the rejection stage (with its pilot's budget, made on first
    use)."""

    def __init__(self, model: ir.Model, request: SolveRequest) -> None:
        validate(model, request)
        check_request(model, request)
        self.model, self.request = model, request
        # Never-occurring signals the request does not ask for: forbidden in the first pass.
        asked = {*request.require, *request.forbid, *(pin.signal for pin in request.pinned)}
        self.zeros = tuple(s.id for s in model.signals if never_occurs(s) and s.id not in asked)
        # Without them, a proof only sends us to the second pass: CP-SAT need not explain it
        # (docs/sampler.md "Proofs").  (Its seed plays no part: each pass is given its own.)
        self.first = (replace(request, forbid=(*request.forbid, *self.zeros),
                              cpsat=replace(request.cpsat, explain=False))
                      if self.zeros else request)
        self._rejection: Rejection | None = None

    def rejection(self) -> Rejection | None:
        """The rejection stage of this request (None: it cannot draw it exactly, or its pilot
        found it too costly)."""
        if not applies(self.request):
            return None
        if self._rejection is None:
            self._rejection = Rejection(self.model, self.request)
        return self._rejection if self._rejection.budget.draws else None


class _Run:
    """One request's solve, with what it learns for every seed of it."""

    def __init__(self, walker: GreedySolver, setup: _Setup, request: SolveRequest) -> None:
        self.walker, self.model, self.request, self.setup = walker, setup.model, request, setup
        # The setup may come from another seed of the same request: the first pass is this one's.
        first = setup.first
        self.zeros, self.first = setup.zeros, first if first.seed == request.seed else replace(first, seed=request.seed)
        # Learnt from one seed, true of every seed: no timeline exists without the
        # never-occurring signals; one exists with them.
        self.zeros_needed = False
        self.exists_with_zeros = False

    def one(self, seed: int, *, walk: bool = True) -> Solution:
        """One timeline for ``seed`` and how it was made; NoSolution (a proof, when CP-SAT
        gives one) when there is none."""
        tally = Tally()
        schedule, method = self._one(seed, walk, tally)
        return Solution(schedule, seed, method, tally.attempts, tally.restarts)

    def _one(self, seed: int, walk: bool, tally: Tally) -> tuple[Schedule, str]:
        request = self.request
        stage = self.setup.rejection() if walk else None
        if stage is not None:
            drawn = stage.sample(seed)
            if drawn is not None:
                return drawn, "rejection"
        schedule, method = self._made(seed, walk, tally)
        if walk and applies(request):
            # Rejection is too costly (or missed): the chain from this timeline (mse.solve.chain).
            return (chained(self.model, schedule, seed, request.forbid, request.require, far=method == FALLBACK),
                    f"{method}+chain")
        return schedule, method

    def _made(self, seed: int, walk: bool, tally: Tally) -> tuple[Schedule, str]:
        request = self.request
        if not self.zeros_needed:
            try:
                return self._pass(self.first, seed, walk, tally)
            except NoSolution as failure:
                if not (self.zeros and failure.proven):
                    raise
                self.zeros_needed = True  # a proof: true of every seed of this request
        # No timeline without the never-occurring signals: a constraint may demand some of them.
        # CP-SAT first says whether any timeline exists at all (once per request: the answer
        # does not depend on the seed): when none does, its proof is the answer at once (a
        # second walk would only spend its whole budget failing again).
        found: Schedule | NoSolution | None = None
        if not self.exists_with_zeros:
            try:
                found = self._complete(request, seed)
                self.exists_with_zeros = True
            except NoSolution as failure:
                if failure.proven:
                    raise
                found = failure  # undecided in the time limit: the walk may still find one
        if walk and not request.pinned:
            try:
                return self.walker.one(self.model, request, seed, tally), "walk"
            except NoSolution:
                pass
        if isinstance(found, NoSolution):
            raise found
        return (found if found is not None else self._complete(request, seed)), FALLBACK

    def _pass(self, request: SolveRequest, seed: int, walk: bool, tally: Tally) -> tuple[Schedule, str]:
        if walk and not request.pinned:
            try:
                return self.walker.one(self.model, request, seed, tally), "walk"  # (the seed: ``seed`` alone)
            except NoSolution:
                pass
        return self._complete(request, seed), FALLBACK

    def _complete(self, request: SolveRequest, seed: int) -> Schedule:
        """CP-SAT's timeline for ``seed``; NoSolution (a proof when it has one) otherwise."""
        fallback = get_solver(FALLBACK)
        # (CP-SAT's own rejection stage would repeat the draws this seed's stage missed.)
        complete = replace(request, seed=seed, count=1, objective=None, diverse=False, rejection=False)
        return next(fallback.solutions(self.model, complete)).schedule

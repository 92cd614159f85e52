"""The default solver (``--solver greedy``): the paper's walk, then a complete fallback.

``mse sample`` must return a timeline whenever one exists, and say so with a proof when none
does.  The composition, per timeline (seed ``S + i``):

1. **walk** — the greedy walk of :mod:`mse.solve.greedy` (docs/sampler.md), which backtracks
   to its checkpoints by itself (the repair step); this is the distribution users get;
2. **cpsat** — when the walk gives up (or the request pins signals, which the walk does not
   place), CP-SAT with its default objective, which follows the same probability profile
   (:mod:`mse.ir.profile`), finds a timeline if one exists;
3. **proof** — when CP-SAT proves that none exists, its minimal explanation (file:line of
   every rule in the conflict) is the answer (``NoSolution(proven=True)``).

Signals whose probabilities are both 0 never occur (mse.ir.profile.never_occurs) unless the
request requires or pins them, or no timeline exists without them (a constraint demands
them): they are forbidden in a first pass, allowed in a second one only when the first is
proven infeasible.

Each timeline records how it was made (:attr:`DefaultSolver.methods`: ``walk`` or
``cpsat``; the timeline JSON's ``"method"``).  CP-SAT is reached only through
:func:`mse.solve.protocol.get_solver` and imported only when the walk fails, so sampling a
set the walk solves never loads ortools.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace

from mse import progress
from mse.ir import model as ir
from mse.ir.profile import never_occurs
from mse.ir.schedule import Occurrence, Schedule
from mse.solve.greedy import GreedySolver
from mse.solve.greedy.solver import validate
from mse.solve.protocol import NoSolution, SolveRequest, check_request, derive_seed, get_solver

#: Name of the complete fallback solver, as recorded in ``"method"``.
FALLBACK = "cpsat"


def _same_but_seed(known: SolveRequest, request: SolveRequest) -> bool:
    """``request`` asks what ``known`` asks, for another seed: what :meth:`DefaultSolver.one`
    learnt of ``known`` (validity, never-occurring signals, the walk's request) holds for it.
    A user's loop of one ``solve()`` per seed then pays for it once."""
    if known is request:
        return True
    fields_of = request.__dict__  # (a frozen dataclass without slots: one dict compare)
    return {**known.__dict__, "seed": fields_of["seed"]} == fields_of


class DefaultSolver:
    """``name = "greedy"``: walk → (backtracking) → CP-SAT → proof."""

    name = "greedy"
    supports = frozenset({"stream", "constraint-less", "require", "forbid", "pin"})

    def __init__(self) -> None:
        self.walker = GreedySolver()
        #: How each timeline of the last :meth:`solve` was made ("walk" or "cpsat").
        self.methods: list[str] = []
        #: Walks and backtracks of the last :meth:`solve` (the bench reads them).
        self.attempts = 0
        self.restarts = 0
        # What one solve() learnt of its request, whatever the seed (:meth:`one`): no timeline
        # exists without the never-occurring signals; one exists with them.
        self._zeros_needed = False
        self._exists_with_zeros = False
        # (model, request) -> its never-occurring signals and the walk's first request: the
        # same for every seed, so made once per request rather than once per timeline
        self._first: tuple[ir.Model, SolveRequest, tuple[str, ...], SolveRequest] | None = None

    def solve(self, model: ir.Model, request: SolveRequest) -> list[Schedule]:
        known = self._first
        if known is None or known[0] is not model or not _same_but_seed(known[1], request):
            self._validate(model, request)  # (the seed plays no part in it)
        self.methods, self.attempts, self.restarts = [], 0, 0
        self._zeros_needed = self._exists_with_zeros = False
        schedules = []
        indices = range(request.count)
        # One timeline per call when mse.api streams --count (its own bar counts them).
        for index in progress.each(indices, "sample", unit="timeline") if request.count > 1 else indices:
            schedule, method = self.one(model, request, derive_seed(request.seed, index))
            schedules.append(schedule)
            self.methods.append(method)
        return schedules

    def stream(self, model: ir.Model, request: SolveRequest) -> Iterator[Occurrence]:
        """The walk's stream (each batch handed out at a checkpoint, docs/sampler.md); when the
        walk gives up before its first checkpoint, the fallback's timeline at once."""
        self._validate(model, request)
        self.methods = []
        self._zeros_needed = self._exists_with_zeros = False
        seed = derive_seed(request.seed, 0)
        if not request.pinned:
            first = replace(request, forbid=self._forbidden(model, request))
            streamed = False
            try:
                for occurrence in self.walker.stream(model, first):
                    streamed = True
                    yield occurrence
                self.methods.append("walk")
                return
            except NoSolution:
                if streamed:  # cannot happen: the walk ends at its last commit instead
                    raise
        schedule, method = self.one(model, request, seed, walk=False)
        self.methods.append(method)
        yield from sorted(schedule.occurrences)

    # -- one timeline ---------------------------------------------------------------------------
    def one(self, model: ir.Model, request: SolveRequest, seed: int, *, walk: bool = True) -> tuple[Schedule, str]:
        """One timeline for ``seed`` and how it was made; NoSolution (a proof, when CP-SAT
        gives one) when there is none."""
        known = self._first
        if known is not None and known[0] is model and _same_but_seed(known[1], request):
            zeros, first = known[2], known[3]
        else:
            zeros = self._zeros(model, request)
            # Without the never-occurring signals, a proof only sends us to the second pass:
            # CP-SAT need not explain it (docs/sampler.md "Proofs").
            first = (replace(request, forbid=(*request.forbid, *zeros), options={**request.options, "explain": False})
                     if zeros else request)
            self._first = (model, request, zeros, first)
        if not self._zeros_needed:
            try:
                return self._pass(model, first, seed, walk)
            except NoSolution as failure:
                if not (zeros and failure.proven):
                    raise
                self._zeros_needed = True  # a proof: true of every seed of this request
        # No timeline without the never-occurring signals: a constraint may demand some of them.
        # CP-SAT first says whether any timeline exists at all (once per request: the answer
        # does not depend on the seed): when none does, its proof is the answer at once (a
        # second walk would only spend its whole budget failing again).
        found: Schedule | NoSolution | None = None
        if not self._exists_with_zeros:
            try:
                found = self._complete(model, request, seed)
                self._exists_with_zeros = True
            except NoSolution as failure:
                if failure.proven:
                    raise
                found = failure  # undecided in the time limit: the walk may still find one
        if walk and not request.pinned:
            try:
                return self._walk(model, request, seed), "walk"
            except NoSolution:
                pass
        if isinstance(found, NoSolution):
            raise found
        return (found if found is not None else self._complete(model, request, seed)), FALLBACK

    def _pass(self, model: ir.Model, request: SolveRequest, seed: int, walk: bool) -> tuple[Schedule, str]:
        if walk and not request.pinned:
            try:
                return self._walk(model, request, seed), "walk"
            except NoSolution:
                pass
        return self._complete(model, request, seed), FALLBACK

    def _walk(self, model: ir.Model, request: SolveRequest, seed: int) -> Schedule:
        try:
            return self.walker.one(model, request, seed)  # it reads the seed from ``seed`` alone
        finally:
            self.attempts += self.walker.attempts
            self.restarts += self.walker.restarts
            self.walker.attempts = self.walker.restarts = 0

    @staticmethod
    def _complete(model: ir.Model, request: SolveRequest, seed: int) -> Schedule:
        """CP-SAT's timeline for ``seed``; NoSolution (a proof when it has one) otherwise."""
        fallback = get_solver(FALLBACK)
        complete = replace(request, seed=seed, count=1, objective=None, diverse=False)
        return fallback.solve(model, complete)[0]

    # -- requests -------------------------------------------------------------------------------
    def _validate(self, model: ir.Model, request: SolveRequest) -> None:
        validate(model, request)
        check_request(model, request)

    @staticmethod
    def _zeros(model: ir.Model, request: SolveRequest) -> tuple[str, ...]:
        """Never-occurring signals (both probabilities 0) the request does not ask for."""
        asked = {*request.require, *request.forbid, *(pin.signal for pin in request.pinned)}
        return tuple(s.id for s in model.signals if never_occurs(s) and s.id not in asked)

    def _forbidden(self, model: ir.Model, request: SolveRequest) -> tuple[str, ...]:
        return (*request.forbid, *self._zeros(model, request))

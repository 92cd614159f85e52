"""The CP-SAT backend: exact timelines with OR-Tools (docs/solvers.md).

``ortools`` is imported only inside functions here and in :mod:`mse.solve.cpsat.encode`,
so ``import mse`` and the greedy path never load it.

One timeline is decided *frame by frame*: a timeline of at most SINGLE_FRAME is one frame;
a longer one is cut into windows of WINDOW (a rolling horizon).  Each frame draws its slots
from the probability profile (:mod:`mse.solve.cpsat.prior`) and asks CP-SAT for the
consistent timeline that scores best under the perturbed profile
(:mod:`mse.solve.cpsat.objective`); when the draw is already consistent it is returned
without CP-SAT.  Before any frame, plain requests try the rejection stage
(:mod:`mse.solve.rejection`): prior draws of the whole timeline, the first consistent one
wins (``Solution.method == "rejection"``), an exact sample of the target where the request's
pilot finds that cheap.  A window's model also holds "later" slots for the rest of the timeline,
enough for the witness argument of :mod:`mse.solve.bounds`, so every committed window is
provably completable and a later window never meets a dead end; committed occurrences are
summarised by :mod:`mse.solve.cpsat.horizon`, so the cost per window does not grow with
the elapsed time and :meth:`CpSatSolver.stream` hands out each window as soon as it is
committed.

Where that stage's pilot finds it too costly (or a seed misses), the chain stage
(:mod:`mse.solve.chain`) follows CP-SAT's timeline on those plain requests
(``Solution.method == "cpsat+chain"``): its stationary law is the target.

Every timeline returned by :meth:`CpSatSolver.solve` has passed
:func:`mse.ir.evaluate.check_schedule`.  "Infeasible" is only reported as a proof
(``NoSolution(proven=True)``, with a minimal explanation) when CP-SAT says INFEASIBLE with
enough occurrence slots for the witness argument; a time-out says so.  Searches are bounded
by CP-SAT's *deterministic* time, so that with one worker a seed fixes the timeline whatever
the machine's load.
"""

from __future__ import annotations

import itertools
import random
import time
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import replace

from mse.diagnostics import Diagnostic, argument_error
from mse.ir import model as ir
from mse.ir.evaluate import check_schedule
from mse.ir.schedule import Occurrence, Schedule, to_ticks
from mse.solve.bounds import MAX_SLOTS, atom_mentions, length_bounds, semantic_limit, slot_counts
from mse.solve.chain import chained
from mse.solve.cpsat.encode import Encoding, Frame, build
from mse.solve.cpsat.engine import make_solver
from mse.solve.cpsat.explain import whole_set_span
from mse.solve.cpsat.horizon import Committed
from mse.solve.cpsat.prior import SlotPrior, frame_priors
from mse.solve.cpsat.search import best_positions, decided_occurrences, hint_later, run_search
from mse.solve.protocol import NoSolution, Solution, SolveRequest, SolveResult, check_request, derive_seed, solve_all
from mse.solve.rejection import Rejection, applies

#: Timelines up to this many ticks are decided in one frame.
SINGLE_FRAME = 30_000
#: Window length of the rolling horizon (ticks).
WINDOW = 10_000
#: CP-SAT deterministic time (about seconds) spent on a frame's options (stage 1) ...
SAMPLE_WORK = 0.3
#: ... on a large frame (more than LARGE_SLOTS decided slots) ...
LARGE_WORK = 0.1
LARGE_SLOTS = 40
#: ... and on one --diverse timeline after the first (stage 2, the positions: search.POSITION_WORK).
DIVERSE_WORK = 0.2
#: Gibbs sweeps after CP-SAT (one frame, profile objective): :mod:`mse.solve.cpsat.refine`.
REFINE_SWEEPS = 12


class CpSatSolver:
    """Exact solving with OR-Tools CP-SAT."""

    name = "cpsat"
    supports = frozenset({"pin", "require", "forbid", "objective", "diverse", "constraint-less", "stream"})

    def solutions(self, model: ir.Model, request: SolveRequest) -> Iterator[Solution]:
        """The timelines one by one; with ``diverse`` each depends on those before it."""
        _validate(model, request)
        stage = _rejection(model, request)
        schedules: list[Schedule] = []
        for index in range(max(1, request.count)):
            seed = derive_seed(request.seed, index)
            drawn = stage.sample(seed) if stage is not None else None
            if drawn is not None:
                schedules.append(drawn)
                yield Solution(drawn, seed, "rejection")
                continue
            previous = schedules if request.diverse else []
            schedules.append(solve_one(model, request, seed, previous))
            if stage is not None:  # rejection too costly (or missed): the chain from CP-SAT's timeline
                schedules[-1] = chained(model, schedules[-1], seed, request.forbid, request.require, far=True)
                yield Solution(schedules[-1], seed, "cpsat+chain")
                continue
            yield Solution(schedules[-1], seed)

    def solve(self, model: ir.Model, request: SolveRequest) -> SolveResult:
        return solve_all(self, model, request)

    def stream(self, model: ir.Model, request: SolveRequest) -> Iterator[Occurrence]:
        """The occurrences of one timeline in start order, window by window: each is handed
        out as soon as its window is committed (and checked at the end)."""
        _validate(model, request)
        seed = derive_seed(request.seed, 0)
        if applies(request):  # the timeline :meth:`solutions` gives for this seed, at once
            yield from sorted(next(self.solutions(model, replace(request, count=1))).schedule.occurrences)
            return
        occurrences: list[Occurrence] = []
        for occurrence in _frames(model, request, seed, ()):
            occurrences.append(occurrence)
            yield occurrence
        _verified(model, Schedule.of(to_ticks(request.duration), occurrences), request)


def _rejection(model: ir.Model, request: SolveRequest) -> Rejection | None:
    """The rejection stage for ``request`` (None: not asked, or it cannot draw it exactly)."""
    if not applies(request):
        return None
    return Rejection(model, request)


def _validate(model: ir.Model, request: SolveRequest) -> None:
    check_request(model, request)
    if request.mode not in ("consistent", "constraint-less"):
        raise argument_error(f"unknown mode {request.mode!r} (known: consistent, constraint-less)")
    if request.mode == "constraint-less" and not model.constraints:
        raise argument_error(f"{model.name!r} has no constraints, so no timeline can violate one "
                             "(--mode constraint-less needs a behaviour set with constraints)")
    if request.diverse and to_ticks(request.duration) > SINGLE_FRAME:
        raise argument_error(f"--diverse works on timelines of at most {SINGLE_FRAME // 1000} s")


def _verified(model: ir.Model, schedule: Schedule, request: SolveRequest) -> Schedule:
    """``schedule`` after checking it with the evaluator; an encoding bug raises."""
    violations = check_schedule(model, schedule)
    if request.mode == "constraint-less":
        if not any(v.kind == "constraint" for v in violations):
            raise RuntimeError("CP-SAT produced a consistent timeline in constraint-less mode (a bug)")
        violations = [v for v in violations if v.kind != "constraint"]
    present = {o.signal for o in schedule.occurrences}
    missing = [name for name in request.require if name not in present]
    extra = [name for name in request.forbid if name in present]
    unpinned = [p for p in request.pinned
                if Occurrence(to_ticks(p.start), to_ticks(p.stop), p.signal) not in schedule.occurrences]
    if violations or missing or extra or unpinned:
        details = "; ".join([v.message for v in violations] + [f"{n} missing" for n in missing]
                            + [f"{n} present" for n in extra] + [f"pin {p} missing" for p in unpinned])
        raise RuntimeError(f"CP-SAT produced an inconsistent timeline (a bug): {details}")
    return schedule


def solve_one(
    model: ir.Model, request: SolveRequest, seed: int, previous: Sequence[Schedule] = ()
) -> Schedule:
    """One timeline; NoSolution (with an explanation when proven) when there is none."""
    duration = to_ticks(request.duration)
    schedule = Schedule.of(duration, _frames(model, request, seed, previous))
    return _verified(model, schedule, request)


def _windows(duration: int, single: bool) -> list[tuple[int, int]]:
    if single or duration <= SINGLE_FRAME:
        return [(0, duration)]
    edges = [*list(range(0, duration, WINDOW)), duration]
    if duration - edges[-2] < WINDOW // 2 and len(edges) > 2:
        del edges[-2]  # no sliver of a last window
    return list(itertools.pairwise(edges))


def _mode(request: SolveRequest) -> str:
    return request.objective if request.objective in ("likely", "random") else "sample"


def _frames(model: ir.Model, request: SolveRequest, seed: int, previous: Sequence[Schedule]) -> Iterator[Occurrence]:
    """The occurrences of one timeline, window by window, each window once committed."""
    import ortools.sat.python.cp_model  # noqa: F401  (loading it, ~1 s on a busy machine, is not solving time)

    duration = to_ticks(request.duration)
    windows = _windows(duration, bool(previous) or request.diverse)
    committed = Committed(model, duration)
    later_hints: list[Occurrence] = []
    for index, (begin, end) in enumerate(windows):
        priors = frame_priors(model, duration, begin, end, committed.free_from(), committed.counts,
                              random.Random(f"{seed}/{index}"), mode=_mode(request))
        if len(windows) == 1 and not previous:
            drawn = _draw_if_acceptable(model, request, duration, priors)
            if drawn is not None:
                yield from drawn
                return
        if index > 0 and request.objective not in ("most-signals", "fewest-signals") and not any(
                o.start < end for o in later_hints) and not any(
                p.present and p.choice < len(p.bins) for slots in priors.values() for p in slots):
            # Nothing drawn here and nothing planned here: committing nothing is the best this
            # window can do, and the previous window's plan for the rest still completes it.
            continue
        # The time limit is per window: a long timeline is many small solves, and one
        # budget shared by all of them would cap the duration a user can ask for.
        deadline = time.monotonic() + request.time_limit
        frame = Frame(begin, end, committed.representatives(), dict(committed.counts),
                      frozenset(committed.falsified), _later_counts(model, duration, end, committed))
        solution = _solve_frame(model, request, seed, frame, priors, previous, later_hints,
                                first=index == 0, deadline=deadline)
        if len(windows) == 1 and not previous and request.objective is None:
            solution = list(_refined(model, request, seed, Schedule.of(duration, solution)).occurrences)
        kept = sorted(o for o in solution if o.start < end or end == duration)
        later_hints = [o for o in solution if not (o.start < end or end == duration)]
        committed.commit(kept)
        yield from kept


def _refined(model: ir.Model, request: SolveRequest, seed: int, schedule: Schedule) -> Schedule:
    """Gibbs sweeps from CP-SAT's timeline towards the exact target (:mod:`refine`)."""
    from mse.solve.cpsat.refine import refine

    sweeps = request.cpsat.sweeps if request.cpsat.sweeps is not None else REFINE_SWEEPS
    return refine(model, schedule, random.Random(f"refine/{seed}"), violate=request.mode == "constraint-less",
                  keep=[p.signal for p in request.pinned], require=request.require, forbid=request.forbid,
                  sweeps=sweeps)


def _draw_if_acceptable(model: ir.Model, request: SolveRequest, duration: int,
                        priors: Mapping[str, Sequence[SlotPrior]]) -> list[Occurrence] | None:
    """The prior draw itself when it is what CP-SAT would return: a consistent timeline (or,
    in constraint-less mode, one violating a constraint) meeting the request."""
    if request.pinned or request.objective in ("most-signals", "fewest-signals"):
        return None
    occurrences = [Occurrence(p.start, p.start + p.length, p.signal)
                   for slots in priors.values() for p in slots if p.present and p.choice < len(p.bins)]
    present = {o.signal for o in occurrences}
    if any(name not in present for name in request.require) or any(n in present for n in request.forbid):
        return None
    if any(o.stop > duration for o in occurrences):
        return None
    violations = check_schedule(model, Schedule.of(duration, occurrences))
    constraint_violated = any(v.kind == "constraint" for v in violations)
    if any(v.kind != "constraint" for v in violations):
        return None
    if request.mode == "constraint-less":
        return occurrences if constraint_violated else None
    return None if constraint_violated else occurrences


def _witness(model: ir.Model) -> Mapping[str, int]:
    mentions = atom_mentions(model)
    return {s.id: max(1, mentions[s.id]) for s in model.signals}


def _later_counts(model: ir.Model, duration: int, end: int, committed: Committed) -> dict[str, int]:
    """Later slots of repetitive signals after a window ending at ``end``: the witness bound."""
    if end >= duration:
        return {}
    witness = _witness(model)
    counts = {}
    for signal in model.signals:
        if not signal.repetitive:
            continue
        limit = semantic_limit(signal, duration - end)
        if signal.max_occurrences is not None:
            limit = min(limit, signal.max_occurrences - committed.counts[signal.id])
        # At least two: the second later slot says whether the signal can still *repeat*,
        # which the objective weighs (objective.py, _later_terms).
        counts[signal.id] = max(0, min(limit, max(witness[signal.id], 2), MAX_SLOTS))
    return counts


def _extended(model: ir.Model, priors: Mapping[str, Sequence[SlotPrior]], frame: Frame,
              duration: int) -> tuple[dict[str, list[SlotPrior]], bool]:
    """Priors with at least the witness bound of window slots (extra slots drawn absent),
    and whether window plus later slots now reach the witness bound everywhere."""
    from mse.solve.cpsat.prior import repetitive_priors

    witness = _witness(model)
    end = duration if frame.end is None else frame.end
    extended: dict[str, list[SlotPrior]] = {}
    complete = True
    for signal in model.signals:
        slots = list(priors[signal.id])
        if signal.repetitive and slots:
            free_from = max([frame.begin] + [stop for _, stop in frame.past.get(signal.id, ())])
            _low, _ = length_bounds(signal, duration)
            room = None if signal.max_occurrences is None else signal.max_occurrences - frame.committed.get(
                signal.id, 0)
            limit = min(semantic_limit(signal, duration - free_from), room if room is not None else MAX_SLOTS)
            wanted = min(max(len(slots), witness[signal.id]), limit, MAX_SLOTS)
            if wanted > len(slots):
                drawn = [(p.start, p.start + p.length) for p in slots if p.present]
                slots = repetitive_priors(signal, duration, frame.begin, end, free_from, room, wanted, drawn,
                                          random.Random(f"extend/{signal.id}"))
            needed = min(semantic_limit(signal, duration - free_from), witness[signal.id],
                         room if room is not None else witness[signal.id])
            complete &= len(slots) + frame.later.get(signal.id, 0) >= needed
        extended[signal.id] = slots
    return extended, complete


def _build(model: ir.Model, request: SolveRequest, priors: Mapping[str, Sequence[SlotPrior]],
           frame: Frame, duration: int) -> Encoding:
    free = request.mode == "constraint-less"
    return build(model, duration, {name: len(slots) for name, slots in priors.items()},
                 constraints=not free, violate=free, pins=request.pinned, require=request.require,
                 forbid=request.forbid, frame=frame)


def _solve_frame(
    model: ir.Model,
    request: SolveRequest,
    seed: int,
    frame: Frame,
    priors: Mapping[str, Sequence[SlotPrior]],
    previous: Sequence[Schedule],
    later_hints: Sequence[Occurrence],
    *,
    first: bool,
    deadline: float,
) -> list[Occurrence]:
    """The decided occurrences of one frame (window and later slots)."""
    from ortools.sat.python import cp_model

    from mse.solve.cpsat.objective import set_objective

    duration = to_ticks(request.duration)
    complete = False
    while True:
        enc = _build(model, request, priors, frame, duration)
        stages = set_objective(enc, request.objective, seed, priors, previous, request.require)
        hint_later(enc, later_hints)
        large = (sum(len(enc.decided(s.id)) for s in model.signals) > LARGE_SLOTS
                 or request.cpsat.first)
        work = DIVERSE_WORK if previous else LARGE_WORK if large else SAMPLE_WORK
        work = request.cpsat.work if request.cpsat.work is not None else work
        mixed = bool(previous) or request.objective in ("most-signals", "fewest-signals")
        status, solver = run_search(enc, request, seed, deadline, work, large=large,
                              stage="mixed" if mixed else "options")
        if status in (cp_model.OPTIMAL, cp_model.FEASIBLE):
            if (stages.positions and not large and request.cpsat.positions
                    and stages.position_cost(solver) > 0):
                return best_positions(enc, request, seed, deadline, solver, stages, large=large)
            return decided_occurrences(enc, solver)
        if status != cp_model.INFEASIBLE:
            message = (f"no timeline of {request.duration:g} s found within the time limit of "
                       f"{request.time_limit:g} s; this is not a proof that none exists (raise --time-limit)")
            raise NoSolution([Diagnostic("W401", message, whole_set_span(model))], proven=False, reason=message)
        if complete:
            break
        # Infeasible with the drawn number of slots: retry once with the witness bound of
        # slots, where "infeasible" is a proof (unless MAX_SLOTS cut the bound).
        extended, complete = _extended(model, priors, frame, duration)
        if all(len(extended[name]) == len(slots) for name, slots in priors.items()):
            break
        priors = extended
    if not first:
        raise RuntimeError("a committed window could not be extended (a bug: the later slots proved it could)")
    if not complete:
        message = (f"no timeline of {request.duration:g} s with at most {MAX_SLOTS} occurrences "
                   "per signal; this is not a proof that none exists")
        raise NoSolution([Diagnostic("W401", message, whole_set_span(model))], proven=False, reason=message)
    raise _proven_infeasible(model, request)


def _proven_infeasible(model: ir.Model, request: SolveRequest) -> NoSolution:
    from mse.solve.cpsat.explain import explain

    constraint_less = request.mode == "constraint-less"
    if constraint_less:
        message = (f"no timeline of {request.duration:g} s violates a constraint of {model.name!r}: "
                   "every constraint holds in every timeline that meets the request")
        return NoSolution([Diagnostic("W401", message, whole_set_span(model))], proven=True, reason=message)
    if not request.cpsat.explain:  # the caller only needs the verdict
        message = f"no timeline of {request.duration:g} s exists"
        return NoSolution([Diagnostic("E401", message, whole_set_span(model))], proven=True, reason=message)
    explanation = explain(
        model, request.duration, pinned=request.pinned, require=request.require,
        forbid=request.forbid, time_limit=min(request.time_limit, 5.0),
    )
    if explanation is None:  # the explainer ran out of time before its own proof
        message = f"no timeline of {request.duration:g} s exists"
        return NoSolution([Diagnostic("E401", message, whole_set_span(model))], proven=True, reason=message)
    # proven: the same finding and code as ``mse lint`` (E401); W401 is for "not found, not proven"
    return NoSolution(explanation.diagnostics(model, "E401"), proven=True, reason=explanation.render())


def enumerate_schedules(
    model: ir.Model, duration: float, grid: float, *, limit: int = 100_000, time_limit: float = 30.0
) -> list[Schedule]:
    """Every consistent schedule whose times lie on a grid of ``grid`` seconds (tests: the
    csp oracle must find exactly as many).  Occurrence slots are the semantic limit."""
    from ortools.sat.python import cp_model

    from mse.solve.cpsat.engine import decode

    ticks, step = to_ticks(duration), to_ticks(grid)
    enc = build(model, ticks, slot_counts(model, ticks, complete=False, step=step, exact=True), step=step)
    found: list[Schedule] = []

    class Collector(cp_model.CpSolverSolutionCallback):
        def on_solution_callback(self) -> None:
            found.append(decode(enc, self))
            if len(found) >= limit:
                self.stop_search()

    # No presolve, no probing: with them CP-SAT 9.15's enumeration drops schedules that the
    # model admits (three repetitive face signals, docs/solvers.md "Enumeration"); the
    # search alone enumerates every one.
    solver = make_solver(time_limit, light=True)
    solver.parameters.enumerate_all_solutions = True
    status = solver.solve(enc.cp, Collector())
    if status not in (cp_model.OPTIMAL, cp_model.FEASIBLE, cp_model.INFEASIBLE):
        raise RuntimeError("CP-SAT enumeration did not finish")
    return found

"""One protocol for every solver backend (greedy, cpsat, csp), after CPMpy's solver interface.

A request is the fields every backend reads (:class:`SolveRequest`) plus one typed, frozen
options record per backend (:class:`GreedyOptions`, :class:`CpSatOptions`,
:class:`CspOptions`); a backend reads its own record and ignores the others.  A backend
declares the features it supports; a request asking for anything else is refused with a
clear message instead of being silently ignored.  Every backend answers with the same
:class:`SolveResult` (its :class:`Status` and one :class:`Solution` per timeline) or raises
:class:`NoSolution`, whose status says whether that is a proof.  Backends are imported
lazily by name (:func:`get_solver`) so that ``ortools`` is loaded only when CP-SAT is asked
for.
"""

from __future__ import annotations

import enum
import importlib
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Protocol

from mse.diagnostics import Diagnostic, MseError, argument_error
from mse.ir.model import Model
from mse.ir.schedule import Occurrence, Schedule
from mse.solve.objectives import OBJECTIVES

#: Feature names a backend may support.
FEATURES = frozenset({"pin", "require", "forbid", "objective", "diverse", "stream", "constraint-less", "grid"})


@dataclass(frozen=True, slots=True)
class Pin:
    """A signal that must occur exactly at [start, stop] (seconds)."""

    signal: str
    start: float
    stop: float


@dataclass(frozen=True, slots=True)
class GreedyOptions:
    """What only the greedy walk reads (``--solver greedy`` and ``walk``)."""

    #: Time-stamp length in seconds (None: about 1 s, :data:`mse.solve.greedy.plan.DEFAULT_SLOT`).
    slot: float | None = None
    #: Backtracks without progress before the walk gives up (then the CP-SAT fallback).
    max_restarts: int = 20
    #: Keep the plan of this length for later requests (False: a length planned once, such as
    #: a dialogue's announced episode, is not worth the plan cache's memory).
    cache_plan: bool = True


@dataclass(frozen=True, slots=True)
class CpSatOptions:
    """What only the CP-SAT backend reads (also as the greedy solver's fallback)."""

    #: Search workers (1: a seed fixes the timeline whatever the machine's load).
    workers: int = 1
    #: CP-SAT deterministic time per frame's search (None: by the frame's size and kind).
    work: float | None = None
    #: Spend a second stage placing the occurrences best (off: the first stage's positions).
    positions: bool = True
    #: Gibbs sweeps after CP-SAT (None: :data:`mse.solve.cpsat.solver.REFINE_SWEEPS`).
    sweeps: int | None = None
    #: Search every frame as a large one (the cheaper budget): a first answer quickly.
    first: bool = False
    #: With a proof of infeasibility, also find a minimal explanation (off: the verdict alone).
    explain: bool = True


@dataclass(frozen=True, slots=True)
class CspOptions:
    """What only the python-constraint backend reads."""

    #: Grid step in seconds: every time of a csp timeline is a multiple of it.
    grid: float = 0.5


@dataclass(frozen=True)
class SolveRequest:
    """Everything a backend may be asked; defaults are the CLI's defaults."""

    duration: float = 10.0
    seed: int = 0
    count: int = 1
    mode: str = "consistent"  # or "constraint-less" (the paper's control condition)
    pinned: tuple[Pin, ...] = ()
    require: tuple[str, ...] = ()
    forbid: tuple[str, ...] = ()
    objective: str | None = None  # None: the default (objectives.DEFAULT_OBJECTIVE); else one of OBJECTIVES
    diverse: bool = False
    time_limit: float = 10.0  # seconds per timeline (and per window of a long cpsat one)
    #: Try exact prior draws first where the backend has that stage (``greedy``, ``cpsat``:
    #: :mod:`mse.solve.rejection`).  Off: a dialogue's episodes (the walk's streaming latency,
    #: no pilot per episode) and the default solver's CP-SAT fallback (its own stage already
    #: missed that seed).
    rejection: bool = True
    greedy: GreedyOptions = GreedyOptions()
    cpsat: CpSatOptions = CpSatOptions()
    csp: CspOptions = CspOptions()

    def features(self) -> frozenset[str]:
        used: set[str] = set()
        if self.pinned:
            used.add("pin")
        if self.require:
            used.add("require")
        if self.forbid:
            used.add("forbid")
        if self.objective is not None:
            used.add("objective")
        if self.diverse:
            used.add("diverse")
        if self.mode == "constraint-less":
            used.add("constraint-less")
        return frozenset(used)


class Status(enum.Enum):
    """How a solve ended, the same for every backend."""

    #: Timelines were found, each meeting the request (checked by the one evaluator).
    FEASIBLE = "feasible"
    #: No timeline exists: a proof (CP-SAT's, with a minimal explanation when it has one).
    UNSATISFIABLE = "unsatisfiable"
    #: None was found within the budget (time, backtracks, grid): not a proof.
    UNKNOWN = "unknown"


@dataclass(frozen=True, slots=True)
class Solution:
    """One timeline of a solve and what the backend reports of it."""

    schedule: Schedule
    seed: int
    #: How it was made, when the backend composes several: "rejection", "walk", "cpsat",
    #: "walk+chain" or "cpsat+chain" (the chain stage after either, mse/solve/chain.py) for
    #: ``greedy``; "rejection", "cpsat+chain" or None (its own search) for ``cpsat``.
    method: str | None = None
    #: Walks started and backtracks taken (the greedy walk's; 0 for the others).
    attempts: int = 0
    restarts: int = 0


@dataclass(frozen=True, slots=True)
class SolveResult:
    """What :meth:`Solver.solve` returns: its status and one solution per timeline asked."""

    status: Status
    solutions: tuple[Solution, ...]

    @property
    def schedules(self) -> tuple[Schedule, ...]:
        return tuple(solution.schedule for solution in self.solutions)

    @property
    def methods(self) -> tuple[str | None, ...]:
        return tuple(solution.method for solution in self.solutions)

    @property
    def attempts(self) -> int:
        return sum(solution.attempts for solution in self.solutions)

    @property
    def restarts(self) -> int:
        return sum(solution.restarts for solution in self.solutions)


def derive_seed(seed: int, index: int) -> int:
    """Seed of the ``index``-th timeline of a ``--count`` run: ``seed + index``, so that
    timeline *i* of ``--seed S --count N`` is reproduced alone by ``--seed S+i``."""
    return seed + index


class NoSolution(MseError):
    """No timeline exists (a proof: ``proven=True``, status UNSATISFIABLE) or none was found
    in the budget (status UNKNOWN)."""

    def __init__(self, diagnostics: list[Diagnostic], *, proven: bool, reason: str = "") -> None:
        super().__init__(diagnostics)
        self.proven = proven
        self.reason = reason

    @property
    def status(self) -> Status:
        return Status.UNSATISFIABLE if self.proven else Status.UNKNOWN


class Solver(Protocol):
    """What every backend provides."""

    name: str
    supports: frozenset[str]

    def solutions(self, model: Model, request: SolveRequest) -> Iterator[Solution]:
        """The ``request.count`` timelines one by one, each as soon as it is solved (seeds
        derived with :func:`derive_seed`); raises :class:`NoSolution` when one has none."""
        ...

    def solve(self, model: Model, request: SolveRequest) -> SolveResult:
        """All of :meth:`solutions` at once (:func:`solve_all`)."""
        ...

    def stream(self, model: Model, request: SolveRequest) -> Iterator[Occurrence]:
        """Occurrences of one schedule, each yielded as soon as it is decided (``stream``)."""
        ...


def solve_all(solver: Solver, model: Model, request: SolveRequest) -> SolveResult:
    """Every solution of ``request``: what each backend's ``solve`` returns."""
    return SolveResult(Status.FEASIBLE, tuple(solver.solutions(model, request)))


#: name -> "module:Class"; imported only when used.
BACKENDS: dict[str, str] = {
    "greedy": "mse.solve.default:DefaultSolver",  # the walk, then CP-SAT when it gives up
    "walk": "mse.solve.greedy.solver:GreedySolver",  # the walk alone (no fallback, no proof)
    "cpsat": "mse.solve.cpsat.solver:CpSatSolver",
    "csp": "mse.solve.csp.solver:CspSolver",
}


def get_solver(name: str) -> Solver:
    """The backend called ``name``, imported on first use.  Backends keep nothing between
    calls (what a solve learns of its request lives in that solve), so one instance per name
    serves every caller."""
    solver = _INSTANCES.get(name)
    if solver is not None:
        return solver
    target = BACKENDS.get(name)
    if target is None:
        raise argument_error(f"unknown solver {name!r} (known: {', '.join(BACKENDS)})")
    module_name, class_name = target.split(":")
    module = importlib.import_module(module_name)
    made: Solver = getattr(module, class_name)()
    _INSTANCES[name] = made
    return made


_INSTANCES: dict[str, Solver] = {}


def check_supported(solver: Solver, request: SolveRequest) -> None:
    unsupported = sorted(request.features() - solver.supports)
    if unsupported:
        hint = " (use --solver cpsat)" if solver.name != "cpsat" else ""
        message = f"solver {solver.name!r} does not support {', '.join(unsupported)}{hint}"
        raise argument_error(message)


def check_request(model: Model, request: SolveRequest) -> None:
    """Unknown signals and impossible pins are user errors, not infeasibility."""
    known = model.signal_by_id
    named = [p.signal for p in request.pinned] + list(request.require) + list(request.forbid)
    for name in named:
        if name not in known:
            raise argument_error(f"unknown signal {name!r} in {model.name!r} (known: {', '.join(known)})")
    for pin in request.pinned:
        if not 0 <= pin.start < pin.stop <= request.duration:
            raise argument_error(
                f"pin {pin.signal}@{pin.start:g}-{pin.stop:g} is not inside [0, {request.duration:g}] s")
    if request.objective is not None and request.objective not in OBJECTIVES:
        raise argument_error(f"unknown objective {request.objective!r}")
    if request.duration <= 0:
        raise argument_error("the duration must be positive")

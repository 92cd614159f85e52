"""One protocol for every solver backend (greedy, cpsat, csp).

A backend declares the features it supports; a request asking for anything else is refused
with a clear message instead of being silently ignored.  Backends are imported lazily by
name (:func:`get_solver`) so that ``ortools`` is loaded only when CP-SAT is asked for.
"""

from __future__ import annotations

import importlib
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Protocol

from mse.diagnostics import Diagnostic, MseError, argument_error
from mse.ir.model import Model
from mse.ir.schedule import Occurrence, Schedule

#: Feature names a backend may support.
FEATURES = frozenset({"pin", "require", "forbid", "objective", "diverse", "stream", "constraint-less", "grid"})

OBJECTIVES = ("likely", "random", "most-signals", "fewest-signals")


@dataclass(frozen=True, slots=True)
class Pin:
    """A signal that must occur exactly at [start, stop] (seconds)."""

    signal: str
    start: float
    stop: float


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
    objective: str | None = None  # None: the backend's default
    diverse: bool = False
    time_limit: float = 10.0
    workers: int = 1
    grid: float = 0.5  # csp backend: grid step in seconds
    slot: float | None = None  # greedy backend: time-stamp length (None: about 1 s)
    max_restarts: int = 20  # greedy: backtracks without progress before the fallback
    options: dict[str, object] = field(default_factory=dict)

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


def derive_seed(seed: int, index: int) -> int:
    """Seed of the ``index``-th timeline of a ``--count`` run: ``seed + index``, so that
    timeline *i* of ``--seed S --count N`` is reproduced alone by ``--seed S+i``."""
    return seed + index


class NoSolution(MseError):
    """No timeline exists (a proof: ``proven=True``) or none was found in the budget."""

    def __init__(self, diagnostics: list[Diagnostic], *, proven: bool, reason: str = "") -> None:
        super().__init__(diagnostics)
        self.proven = proven
        self.reason = reason


class Solver(Protocol):
    """What every backend provides."""

    name: str
    supports: frozenset[str]

    def solve(self, model: Model, request: SolveRequest) -> list[Schedule]:
        """``request.count`` schedules (seeds derived with :func:`derive_seed`); raises
        :class:`NoSolution` when there is none."""
        ...

    def stream(self, model: Model, request: SolveRequest) -> Iterator[Occurrence]:
        """Occurrences of one schedule, each yielded as soon as it is decided (``stream``)."""
        ...


#: name -> "module:Class"; imported only when used.
BACKENDS: dict[str, str] = {
    "greedy": "mse.solve.default:DefaultSolver",  # the walk, then CP-SAT when it gives up
    "walk": "mse.solve.greedy:GreedySolver",  # the walk alone (no fallback, no proof)
    "cpsat": "mse.solve.cpsat:CpSatSolver",
    "csp": "mse.solve.csp:CspSolver",
}


def get_solver(name: str) -> Solver:
    target = BACKENDS.get(name)
    if target is None:
        raise argument_error(f"unknown solver {name!r} (known: {', '.join(BACKENDS)})")
    module_name, class_name = target.split(":")
    module = importlib.import_module(module_name)
    solver: Solver = getattr(module, class_name)()
    return solver


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
    if request.objective is not None and request.objective not in (
        "likely", "random", "most-signals", "fewest-signals"):
        raise argument_error(f"unknown objective {request.objective!r}")
    if request.duration <= 0:
        raise argument_error("the duration must be positive")

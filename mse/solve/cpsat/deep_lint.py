"""Solver-backed lint (W401-W406): questions about *all* consistent timelines.

One switchable CP-SAT model (:mod:`mse.solve.cpsat.encode`) answers every question by
assumptions, each query with a small time limit:

* W401 no consistent timeline at all (the message carries the minimal explanation);
* W402 dead signal: it occurs in no consistent timeline;
* W403 constraint never instantiated: none of its trigger signals can occur;
* W404 redundant constraint: the other constraints imply it (it cannot be violated
  while they hold);
* W405 signal forced: it occurs in every consistent timeline although no constraint
  requires it directly (``exists(s)`` on its own or in a top-level ``and``);
* W406 probability profile contradicted: probability_start > 0, but the signal can never
  start in the first time stamp (``FIRST_STAMP``).

Every consistent timeline found on the way is *harvested*: a signal seen present is not
dead, one seen absent is not forced, and so on, which skips most queries.  A query that
hits its time limit is reported as undecided, with the same code, rather than guessed.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

from mse.diagnostics import Diagnostic, Span
from mse.ir import model as ir
from mse.ir.evaluate import intervals_of, is_instantiated
from mse.ir.schedule import to_ticks
from mse.solve.bounds import slot_counts
from mse.solve.cpsat.encode import Encoding, Lit, build, lnot

#: Length of the first time stamp (the greedy sampler's slot is about 1 s).
FIRST_STAMP = 1.0
#: Default time limit of one query, in seconds.
QUERY_TIME = 0.5


@dataclass
class _Seen:
    """What harvested consistent timelines have shown."""

    present: set[str] = field(default_factory=set)
    absent: set[str] = field(default_factory=set)
    instantiated: set[str] = field(default_factory=set)
    early: set[str] = field(default_factory=set)


class _Linter:
    def __init__(self, model: ir.Model, duration: float, query_time: float) -> None:
        self.model = model
        self.duration = duration
        self.ticks = to_ticks(duration)
        self.query_time = query_time
        counts = slot_counts(model, self.ticks, complete=True)
        self.enc: Encoding = build(model, self.ticks, counts, switchable=True)
        self.rules = list(self.enc.enable)
        self.stamp = min(self.ticks, to_ticks(FIRST_STAMP))
        self.early: dict[str, Lit] = {}
        for signal_id, slots in self.enc.slots.items():
            if slots:  # slot 0 is the earliest occurrence (slots are ordered)
                starts_early = self.enc.cp.new_bool_var(f"early:{signal_id}")
                self.enc.cp.add_implication(starts_early, slots[0].present)
                self.enc.cp.add(slots[0].start <= self.stamp - 1).only_enforce_if(starts_early)
                self.early[signal_id] = starts_early
            else:
                self.early[signal_id] = False
        self.seen = _Seen()
        self.redundant: list[str] = []
        self.found: list[Diagnostic] = []

    def query(self, extra: Sequence[Lit], *, rules: Sequence[str] | None = None,
              harvest: bool = True) -> str:
        """'feasible' | 'infeasible' | 'unknown' under ``rules`` (default all) and ``extra``."""
        from ortools.sat.python import cp_model

        from mse.solve.cpsat.engine import decode, make_solver

        if any(lit is False for lit in extra):
            return "infeasible"
        literals: list[Lit] = [self.enc.enable[k] for k in (self.rules if rules is None else rules)]
        literals += [lit for lit in extra if lit is not True]
        self.enc.cp.clear_assumptions()
        self.enc.cp.add_assumptions(literals)
        # Presolve costs ten times more than the search on these small models: try
        # without it first, and with it only when the light search runs out of time.
        for light in (True, False):
            solver = make_solver(self.query_time / 2 if light else self.query_time, light=light)
            status = solver.solve(self.enc.cp)
            if status != cp_model.UNKNOWN:
                break
        if status in (cp_model.OPTIMAL, cp_model.FEASIBLE):
            if harvest:
                self._harvest(decode(self.enc, solver))
            return "feasible"
        return "infeasible" if status == cp_model.INFEASIBLE else "unknown"

    def _harvest(self, schedule: object) -> None:
        from mse.ir.schedule import Schedule

        assert isinstance(schedule, Schedule)
        intervals = intervals_of(schedule)
        for signal in self.model.signals:
            occurrences = intervals.get(signal.id)
            if occurrences:
                self.seen.present.add(signal.id)
                if min(o[0] for o in occurrences) < self.stamp:
                    self.seen.early.add(signal.id)
            else:
                self.seen.absent.add(signal.id)
        for constraint in self.model.constraints:
            if is_instantiated(constraint, intervals):
                self.seen.instantiated.add(constraint.id)

    def report(self, code: str, message: str, span: Span, status: str) -> None:
        if status == "unknown":
            message = f"undecided within {self.query_time:g} s: {message}?"
        self.found.append(Diagnostic(code, message, span))

    # -- the rules ---------------------------------------------------------------------------
    def run(self) -> list[Diagnostic]:
        status = self.query([])
        if status != "feasible":
            self._no_timeline(status)
            return self.found
        self._signals()
        self._constraints()
        return self.found

    def _no_timeline(self, status: str) -> None:
        from mse.solve.cpsat.explain import explain

        if status == "unknown":
            self.report("W401", f"is there a consistent timeline of {self.duration:g} s",
                        Span(self.model.path), status)
            return
        explanation = explain(self.model, self.duration, time_limit=max(1.0, 4 * self.query_time))
        message = (explanation.render() if explanation is not None
                   else f"no consistent timeline of {self.duration:g} s")
        self.found.append(Diagnostic("W401", message, Span(self.model.path)))

    def _signals(self) -> None:
        required = _directly_required(self.model)
        for signal in self.model.signals:
            occurs = self.enc.occurs[signal.id]
            what = f"{self.duration:g} s"
            if signal.id not in self.seen.present:
                status = self.query([occurs])
                if status != "feasible":
                    self.report("W402", f"signal {signal.id!r} occurs in no consistent timeline "
                                f"of {what}", signal.span, status)
                    continue
            if signal.id not in self.seen.absent and signal.id not in required:
                status = self.query([lnot(occurs)])
                if status != "feasible":
                    self.report("W405", f"signal {signal.id!r} occurs in every consistent timeline "
                                f"of {what} although no constraint requires it directly",
                                signal.span, status)
            if signal.probability_start > 0 and signal.id not in self.seen.early:
                status = self.query([self.early[signal.id]])
                if status != "feasible":
                    self.report("W406", f"signal {signal.id!r} has probability_start "
                                f"{signal.probability_start:g} but can never start in the first "
                                f"{self.stamp / 1000:g} s", signal.span, status)

    def _constraints(self) -> None:
        for constraint in self.model.constraints:
            if constraint.triggers and constraint.id not in self.seen.instantiated:
                status = self.query([self.enc.instantiated[constraint.id]])
                if status != "feasible":
                    names = ", ".join(sorted(constraint.triggers))
                    self.report("W403", f"constraint {constraint.id!r} is never instantiated: its "
                                f"trigger signals ({names}) never occur in a consistent timeline "
                                f"of {self.duration:g} s", constraint.span, status)
                    continue
            key = f"constraint:{constraint.id}"
            others = [k for k in self.rules if k not in (key, *self.redundant)]
            status = self.query([self.enc.violated[constraint.id]], rules=others, harvest=False)
            if status != "feasible":
                self.report("W404", f"constraint {constraint.id!r} is redundant: the other rules "
                            f"imply it for timelines of {self.duration:g} s", constraint.span, status)
                if status == "infeasible":
                    # Dropped from later checks: of two equivalent constraints only the
                    # second is reported, so removing every W404 constraint stays safe.
                    self.redundant.append(key)


def _directly_required(model: ir.Model) -> frozenset[str]:
    """Signals a constraint requires in so many words: ``exists(s)`` alone or in a
    top-level ``and`` of a constraint without trigger signals (always evaluated)."""
    required: set[str] = set()
    for constraint in model.constraints:
        if constraint.triggers:
            continue
        expr = constraint.expr
        parts = expr.operands if isinstance(expr, ir.And) else (expr,)
        required.update(p.signal for p in parts if isinstance(p, ir.Exists))
    return frozenset(required)


def deep_lint(model: ir.Model, duration: float = 10.0, *, query_time: float = QUERY_TIME) -> list[Diagnostic]:
    """The W4xx diagnostics of ``model`` for timelines of ``duration`` seconds."""
    return _Linter(model, float(duration), query_time).run()

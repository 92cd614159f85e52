"""Solver-backed lint (E401, W401-W406): questions about *all* consistent timelines.

* E401 no consistent timeline at all: an error, with the minimal explanation at file:line
  (W401 when it could not be decided within the time limit);
* W402 dead signal: it occurs in no consistent timeline;
* W403 constraint never instantiated: none of its trigger signals can occur;
* W404 redundant constraint: the other constraints imply it (it cannot be violated
  while they hold);
* W405 signal forced: it occurs in every consistent timeline although no constraint
  requires it directly (``exists(s)`` on its own or in a top-level ``and``);
* W406 probability profile contradicted: probability_start > 0, but the signal can never
  start in the first time stamp (``FIRST_STAMP``).

The first question is answered by the sampler itself (a consistent timeline, or a proof and
its explanation).  Every consistent timeline found on the way is *harvested*: a signal seen
present is not dead, one seen absent is not forced, and so on, which skips most questions.
The others go to :class:`mse.solve.cpsat.oracle.Oracle`, which tries answers that cost the
same whatever the size of the set (moving a few signals of a known timeline; disproving on
the constraints near the question) before asking one model of the whole set.  So lint grows
about linearly with the size of the set.  A query that hits its time limit is reported as
undecided, with the same code, rather than guessed.
"""

from __future__ import annotations

import time

from mse.diagnostics import Diagnostic, Span
from mse.ir import model as ir
from mse.ir.evaluate import constraint_status, intervals_of, is_instantiated
from mse.ir.schedule import to_ticks
from mse.solve.cpsat.encode import Encoding, Lit, lnot
from mse.solve.cpsat.explain import whole_set_span
from mse.solve.cpsat.objective import required_signals
from mse.solve.cpsat.oracle import Oracle, Question

#: Length of the first time stamp (the greedy sampler's slot is about 1 s).
FIRST_STAMP = 1.0
#: Default budget of one query, in seconds of CP-SAT deterministic time (oracle.py).
QUERY_TIME = 0.5
#: Timelines sampled first (each harvested), with this much CP-SAT work each.
SAMPLES = 1
SAMPLE_WORK = 0.02
SAMPLE_TIME = 10.0
#: CPU seconds spent in all on questions only the whole set could answer (after the cheap steps);
#: questions left then are summed up in one W400 note instead of being asked.
WHOLE_BUDGET = 2.0
#: CPU seconds for all of one set's questions, counted from the start (whether a timeline exists,
#: which is always answered); questions left then are listed in one W400 note.  None: no
#: limit (``mse lint --deep-budget 0``).
LINT_BUDGET: float | None = 4.0


def early_literal(enc: Encoding, signal_id: str, stamp: int) -> Lit:
    """'the first occurrence of ``signal_id`` starts before ``stamp``' in ``enc``."""
    slots = enc.decided(signal_id)
    if not slots:
        return False
    literal = enc.cp.new_bool_var(f"early:{signal_id}")
    enc.cp.add_implication(literal, slots[0].present)
    enc.cp.add(slots[0].start <= stamp - 1).only_enforce_if(literal)
    return literal


def _occurs(name: str) -> Question:
    return Question(frozenset({name}), lambda iv: bool(iv.get(name)), lambda enc: [enc.occurs[name]])


def _absent(name: str) -> Question:
    return Question(frozenset({name}), lambda iv: not iv.get(name), lambda enc: [lnot(enc.occurs[name])])


def _early(name: str, stamp: int) -> Question:
    return Question(frozenset({name}), lambda iv: any(a < stamp for a, _ in iv.get(name, ())),
                    lambda enc: [early_literal(enc, name, stamp)])


def _instantiated(constraint: ir.Constraint) -> Question:
    return Question(constraint.triggers, lambda iv: is_instantiated(constraint, iv),
                    lambda enc: [enc.instantiated[constraint.id]])


def _violated(constraint: ir.Constraint, ticks: int) -> Question:
    return Question(ir.mentioned_signals(constraint.expr),
                    lambda iv: constraint_status(constraint, iv, ticks) is False,
                    lambda enc: [enc.violated[constraint.id]], drop=constraint.id)


class _Linter:
    def __init__(self, model: ir.Model, duration: float, query_time: float, budget: float | None) -> None:
        self.model = model
        self.budget = budget
        self.began = time.process_time()
        self.unasked: list[str] = []  # questions not asked once the budget was spent
        self.duration = duration
        self.ticks = to_ticks(duration)
        self.query_time = query_time
        self.stamp = min(self.ticks, to_ticks(FIRST_STAMP))
        self.oracle = Oracle(model, self.ticks, query_time, self.stamp)
        self.found: list[Diagnostic] = []
        self.skipped: list[str] = []  # questions not asked: "CODE subject"

    def report(self, code: str, message: str, span: Span, status: str) -> None:
        if status == "unknown":
            message = f"undecided within {self.query_time:g} s: {message}?"
        self.found.append(Diagnostic(code, message, span))

    def run(self) -> list[Diagnostic]:
        if not self._sample():
            return self.found
        self._signals()
        self._constraints()
        if self.unasked:
            self.found.append(Diagnostic(
                "W400", f"{len(self.unasked)} question(s) not asked: the lint budget of {self.budget:g} CPU "
                f"seconds was spent (mse lint --deep-budget 0 asks them all; first: "
                f"{', '.join(self.unasked[:5])})", whole_set_span(self.model)))
        if self.skipped:
            self.found.append(Diagnostic(
                "W400", f"{len(self.skipped)} question(s) left undecided: neither a nearby timeline nor the "
                f"constraints around them decided them, and the {WHOLE_BUDGET:g} s budget for questions about "
                f"the whole set was spent (first: {', '.join(self.skipped[:5])})", whole_set_span(self.model)))
        return self.found

    def _sample(self) -> bool:
        """Harvest a few sampled timelines (the first, made sparse, becomes the oracle's base);
        False, with E401 or W401 reported, when there is none."""
        from mse.solve.cpsat.solver import solve_one
        from mse.solve.protocol import CpSatOptions, NoSolution, SolveRequest

        for seed in range(SAMPLES):
            # Any consistent timeline will do: a short search, no position stage, no sweeps.
            # The wall-clock limit only matters when the deterministic budget finds nothing:
            # as generous as `mse sample`'s default, so a busy machine does not turn a
            # feasible set into "undecided".
            request = SolveRequest(duration=self.duration, seed=seed, time_limit=max(SAMPLE_TIME, 4 * self.query_time),
                                   cpsat=CpSatOptions(work=SAMPLE_WORK, positions=False, sweeps=0, first=True))
            try:
                intervals = intervals_of(solve_one(self.model, request, seed))
            except NoSolution as error:
                if seed > 0:
                    break
                if error.proven:
                    self.found.extend(Diagnostic("E401", d.message, d.span) for d in error.diagnostics)
                else:
                    self.report("W401", f"is there a consistent timeline of {self.duration:g} s",
                                whole_set_span(self.model), "unknown")
                return False
            self.oracle.harvest(intervals)
            if seed == 0:
                self.oracle.set_base(intervals)
        return True

    def _ask(self, question: Question) -> str:
        if self.budget is not None and time.process_time() - self.began > self.budget:
            return "unasked"
        return self.oracle.ask(question, whole=self.oracle.whole_seconds < WHOLE_BUDGET)

    def _finding(self, code: str, subject: str, status: str, message: str, span: Span) -> bool:
        """Report ``message`` unless ``status`` is 'feasible' (nothing to report) or 'skipped'
        (remembered for the W400 note); True when something is wrong or undecided."""
        if status == "skipped":
            self.skipped.append(f"{code} {subject}")
            return False
        if status == "unasked":
            self.unasked.append(f"{code} {subject}")
            return False
        if status == "feasible":
            return False
        self.report(code, message, span, status)
        return True

    def _signals(self) -> None:
        required = required_signals(self.model)
        what = f"{self.duration:g} s"
        seen = self.oracle.seen
        stamp = self.stamp
        for signal in self.model.signals:
            name = signal.id
            status = "feasible" if name in seen.present else self._ask(_occurs(name))
            if self._finding("W402", name, status, f"signal {name!r} occurs in no consistent timeline of {what}",
                             signal.span):
                continue
            if name not in seen.absent and name not in required:
                self._finding("W405", name, self._ask(_absent(name)),
                              f"signal {name!r} occurs in every consistent timeline of {what} although no "
                              "constraint requires it directly", signal.span)
            if signal.probability_start > 0 and name not in seen.early:
                self._finding("W406", name, self._ask(_early(name, stamp)),
                              f"signal {name!r} has probability_start {signal.probability_start:g} but can never "
                              f"start in the first {stamp / 1000:g} s", signal.span)

    def _constraints(self) -> None:
        for constraint in self.model.constraints:
            key = constraint.id
            if constraint.triggers and key not in self.oracle.seen.instantiated:
                names = ", ".join(sorted(constraint.triggers))
                if self._finding("W403", key, self._ask(_instantiated(constraint)),
                                 f"constraint {key!r} is never instantiated: its trigger signals ({names}) never "
                                 f"occur in a consistent timeline of {self.duration:g} s", constraint.span):
                    continue
            status = self._ask(_violated(constraint, self.ticks))
            self._finding("W404", key, status, f"constraint {key!r} is redundant: the other rules imply it for "
                          f"timelines of {self.duration:g} s", constraint.span)
            if status == "infeasible":
                # Dropped from later checks: of two equivalent constraints only the
                # second is reported, so removing every W404 constraint stays safe.
                self.oracle.redundant.append(key)


def deep_lint(model: ir.Model, duration: float = 10.0, *, query_time: float = QUERY_TIME,
              budget: float | None = LINT_BUDGET) -> list[Diagnostic]:
    """The E401/W4xx diagnostics of ``model`` for timelines of ``duration`` seconds; after
    ``budget`` CPU seconds (None: no limit) the questions left are summed up in a W400 note."""
    return _Linter(model, float(duration), query_time, budget).run()

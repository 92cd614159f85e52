"""Does a set of rules imply a constraint?  The CP-SAT check behind redundancy and recovery.

``rules ⊨ c`` at duration D when no timeline of D that obeys the rules (the signals'
durations and occurrence counts, exclusive modalities, the enabled constraints) violates
``c``: the model "rules and violated(c)" is infeasible.  One switchable encoding
(:func:`mse.solve.cpsat.encode.build`, the same one deep lint uses) holds every constraint;
each question switches constraints on with assumptions, so the model is built once.  The
slots per signal are the witness bound (:func:`mse.solve.bounds.slot_counts` with
``complete=True``), so "infeasible" is a proof for that duration.

A signal that the constraints name but the rules' model does not declare is added as a free
signal (any length, any number of times): the rules say nothing about it.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import replace
from typing import Literal

from mse.ir import model as ir
from mse.solve.bounds import slot_counts
from mse.solve.cpsat.encode import Lit, build
from mse.solve.cpsat.engine import make_solver

Answer = Literal["yes", "no", "unknown"]
#: Seconds one implication question may take (twice: without, then with presolve).
QUERY_TIME = 1.0


class ImplicationChecker:
    """Questions "do these constraints imply that one?" over one model and extra constraints."""

    def __init__(self, model: ir.Model, extra: Sequence[ir.Expr] = (), *, duration: int,
                 query_time: float = QUERY_TIME) -> None:
        """``model`` gives signals, modalities and constraints (ids as in the model);
        ``extra`` constraints get the ids ``extra:0``, ``extra:1``... ; ``duration`` in ms."""
        known = set(model.signal_by_id)
        named: set[str] = set()
        constraints = list(model.constraints)
        for number, expr in enumerate(extra):
            constraints.append(ir.Constraint(f"extra:{number}", expr))
        for constraint in constraints:
            named |= ir.mentioned_signals(constraint.expr)
        free = tuple(
            ir.Signal(id=name, modality="__free__", lexeme=name, repetitivity=1)
            for name in sorted(named - known)
        )
        self.model = replace(model, signals=model.signals + free, constraints=tuple(constraints))
        self.duration = duration
        self.query_time = query_time
        counts = slot_counts(self.model, duration, complete=True)
        self.enc = build(self.model, duration, counts, switchable=True)
        self.structural: list[Lit] = [lit for key, lit in self.enc.enable.items()
                                      if not key.startswith("constraint:")]

    def implied(self, target: str, by: Iterable[str]) -> Answer:
        """Do the constraints ``by`` (ids) imply constraint ``target`` (an id)?"""
        violated = self.enc.violated[target]
        if violated is False:
            return "yes"
        assumptions = list(self.structural)
        assumptions += [self.enc.enable[f"constraint:{name}"] for name in by if name != target]
        if violated is not True:
            assumptions.append(violated)
        status = self._solve(assumptions)
        return {"infeasible": "yes", "feasible": "no"}.get(status, "unknown")  # type: ignore[return-value]

    def consistent(self, by: Iterable[str]) -> str:
        """'feasible' | 'infeasible' | 'unknown': is there a timeline obeying ``by``?"""
        assumptions = list(self.structural) + [self.enc.enable[f"constraint:{name}"] for name in by]
        return self._solve(assumptions)

    def reaches(self, x: tuple[str, str], y: tuple[str, str], by: Iterable[str], value: float, *,
                largest: bool) -> str:
        """Is there a timeline obeying ``by`` in which both signals occur and ``y - x``
        (``x``, ``y`` are (signal, edge) of their first occurrences, in ms) is at most
        ``value`` (at least, with ``largest``)?  'feasible' | 'infeasible' | 'unknown'."""
        first, second = self.enc.slots.get(x[0]), self.enc.slots.get(y[0])
        if not first or not second:
            return "unknown"
        left = first[0].start if x[1] == "start" else first[0].stop
        right = second[0].start if y[1] == "start" else second[0].stop
        cp = self.enc.cp
        switch = cp.new_bool_var("")
        limit = math.ceil(value) if largest else math.floor(value)
        if largest:
            cp.add(right - left >= limit).only_enforce_if(switch)
        else:
            cp.add(right - left <= limit).only_enforce_if(switch)
        assumptions = list(self.structural) + [self.enc.enable[f"constraint:{name}"] for name in by]
        return self._solve([*assumptions, first[0].present, second[0].present, switch])

    def _solve(self, assumptions: list[Lit]) -> str:
        from ortools.sat.python import cp_model

        if any(lit is False for lit in assumptions):
            return "infeasible"
        cp = self.enc.cp
        cp.clear_assumptions()
        cp.add_assumptions([lit for lit in assumptions if lit is not True])
        status = cp_model.UNKNOWN
        for light in (True, False):
            solver = make_solver(self.query_time / 2 if light else self.query_time, light=light)
            status = solver.solve(cp)
            if status != cp_model.UNKNOWN:
                break
        if status in (cp_model.OPTIMAL, cp_model.FEASIBLE):
            return "feasible"
        return "infeasible" if status == cp_model.INFEASIBLE else "unknown"

"""Why no timeline exists: a minimal set of rules that cannot hold together.

Every rule a user can be blamed for — each constraint, each signal's duration bounds,
each exclusive modality (the occurrence rules), each pin, require and forbid — is
guarded by an assumption literal (:mod:`mse.solve.cpsat.encode`, ``switchable``).
CP-SAT's *sufficient assumptions for infeasibility* give a first core; deletion-based
shrinking then drops every item whose removal keeps the problem infeasible, so the result
is minimal (every item is needed) unless a query ran out of time (``minimal=False``).
The requested duration itself is always part of the conflict and heads the message.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from mse.diagnostics import Diagnostic, Span
from mse.ir import model as ir
from mse.ir.schedule import to_ticks
from mse.solve.bounds import slot_counts
from mse.solve.cpsat.encode import Encoding, Item, build
from mse.solve.protocol import Pin

#: One item of an explanation: id, kind, span (file:line) and text.
ExplanationItem = Item

#: Blame the user's constraints last: rules are tried for deletion first.
_DELETION_ORDER = {"duration": 0, "occurrence rule": 1, "forbid": 2, "require": 3, "pin": 4,
                   "constraint": 5}


def where(span: Span) -> str:
    """``file:line`` (or just the file) of a span."""
    return f"{span.path}:{span.line}" if span.line > 0 else span.path


def whole_set_span(model: ir.Model) -> Span:
    """Where a finding about the whole set points: its first constraint (else first signal)."""
    spans = [c.span for c in model.constraints] + [s.span for s in model.signals]
    return next((span for span in spans if span.line > 0), Span(model.path))


@dataclass(frozen=True)
class Explanation:
    """No timeline of ``duration`` seconds: ``items`` cannot hold together.

    ``proven`` is False when not even the infeasibility could be decided in the time limit
    (``items`` is then empty); ``minimal`` is False when some shrinking step timed out."""

    duration: float
    items: tuple[Item, ...]
    expression: str = ""
    minimal: bool = True
    proven: bool = True

    @staticmethod
    def label(item: Item) -> str:
        return item.id if item.kind == "constraint" else f"{item.id} [{item.kind}]"

    def render(self) -> str:
        if not self.proven:
            return (f"no timeline of {self.duration:g} s found within the time limit "
                    "(undecided: neither a timeline nor a proof)")
        parts = [f"{self.label(item)} ({where(item.span)}) {item.text}" for item in self.items]
        note = "" if self.minimal else " (time limit reached: the set may not be minimal)"
        return f"no timeline of {self.duration:g} s: " + " … ".join(parts) + note

    def diagnostics(self, model: ir.Model, code: str = "W401") -> list[Diagnostic]:
        """One diagnostic carrying the whole explanation, at the first of its items the file
        holds (a constraint first; every item's file:line is in the message)."""
        located = [item for item in self.items if item.span.line > 0 and item.span.path == model.path]
        located.sort(key=lambda item: item.kind != "constraint")
        span = located[0].span if located else whole_set_span(model)
        return [Diagnostic(code, self.render(), span)]


def _status(enc: Encoding, keys: Sequence[str], time_limit: float, workers: int) -> tuple[str, list[str]]:
    """'feasible' | 'infeasible' | 'unknown' with ``keys`` assumed, and a sufficient core."""
    from ortools.sat.python import cp_model

    from mse.solve.cpsat.engine import make_solver

    enc.cp.clear_assumptions()
    enc.cp.add_assumptions([enc.enable[k] for k in keys])
    # Light search first (no presolve: ten times cheaper on these models), then the
    # default parameters when the light one runs out of its half of the time.
    for light in (True, False):
        solver = make_solver(time_limit / 2 if light else time_limit, workers, light=light)
        status = solver.solve(enc.cp)
        if status != cp_model.UNKNOWN:
            break
    if status in (cp_model.OPTIMAL, cp_model.FEASIBLE):
        return "feasible", []
    if status != cp_model.INFEASIBLE:
        return "unknown", []
    by_index = {enc.enable[k].index: k for k in keys}
    core = [by_index[i] for i in solver.sufficient_assumptions_for_infeasibility() if i in by_index]
    return "infeasible", core or list(keys)


def explain(
    model: ir.Model,
    duration: float,
    *,
    pinned: Sequence[Pin] = (),
    require: Sequence[str] = (),
    forbid: Sequence[str] = (),
    time_limit: float = 10.0,
    workers: int = 1,
    constraints: bool = True,
    **_ignored: object,
) -> Explanation | None:
    """A minimal conflicting set when no timeline of ``duration`` seconds exists, else None.

    ``time_limit`` bounds the whole search (the first query gets most of it)."""
    import time

    deadline = time.monotonic() + max(0.05, time_limit)
    ticks = to_ticks(duration)
    counts = slot_counts(model, ticks, complete=True, pins=[p.signal for p in pinned])
    # A signal too long for the timeline still gets a slot, so that its duration rule
    # can be blamed (switched off) instead of the constraints that need it.
    counts = {signal: max(1, count) for signal, count in counts.items()}
    enc = build(model, ticks, counts, switchable=True, constraints=constraints,
                pins=pinned, require=require, forbid=forbid)
    everything = list(enc.enable)
    status, core = _status(enc, everything, max(0.05, time_limit * 0.5), workers)
    if status == "feasible":
        return None
    if status == "unknown":
        return Explanation(duration, (), model.name, minimal=False, proven=False)
    minimal = True
    current = sorted(core, key=lambda k: (_DELETION_ORDER[enc.items[k].kind], everything.index(k)))
    for key in list(current):
        if key not in current:
            continue
        remaining = deadline - time.monotonic()
        if remaining <= 0.01:
            minimal = False
            break
        trial = [k for k in current if k != key]
        status, smaller = _status(enc, trial, remaining, workers)
        if status == "infeasible":
            kept = set(smaller)
            current = [k for k in trial if k in kept]
        elif status == "unknown":
            minimal = False
    ordered = sorted(current, key=everything.index)
    return Explanation(duration, tuple(enc.items[k] for k in ordered), model.name, minimal=minimal)

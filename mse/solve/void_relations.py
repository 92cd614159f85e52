"""N407: a relation that is void in most of the timelines where it could matter.

A relational atom is *unknown* while a signal it names is absent (docs/semantics.md), so a
bare ``includes(lean, head)`` never stops *head* from occurring without *lean*.  Whether that
happens rarely or almost always depends on the probabilities and on the other constraints
together, so the rule measures it: it samples timelines with the walk and counts, among those
where one of the relation's signals occurs, how many leave it unknown.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from mse.diagnostics import Diagnostic
from mse.ir import model as ir
from mse.ir.evaluate import intervals_of
from mse.ir.evaluate.semantics import evaluate_expr
from mse.ir.printer import expr_text
from mse.ir.schedule import Schedule, to_ticks

#: Timelines sampled per set (the walk takes about a millisecond each).
SAMPLES = 200
#: Warn when the relation is unknown in more than this share of the timelines that show one of
#: its signals, and at least this many such timelines were seen.
VOID_SHARE = 0.9
MIN_SEEN = 20


def _bare_relations(model: ir.Model) -> Iterable[tuple[ir.Constraint, ir.Relation | ir.Compare]]:
    """Constraints that are one relational atom between two signals, with no ``exists`` guard.
    ``excludes`` is left out: "never together" is meant to hold trivially when one is absent."""
    for constraint in model.constraints:
        expr = constraint.expr
        if isinstance(expr, ir.Relation) and expr.kind == "excludes":
            continue
        if isinstance(expr, ir.Relation | ir.Compare) and len(set(ir.atom_signals(expr))) == 2:
            yield constraint, expr


def void_relations(model: ir.Model, schedules: Sequence[Schedule], duration: float) -> list[Diagnostic]:
    """N407 for each bare relation left unknown in most sampled timelines that show one of its
    signals (``schedules``: consistent timelines of ``model`` at ``duration`` seconds)."""
    ticks = to_ticks(duration)
    found: list[Diagnostic] = []
    every = [intervals_of(schedule) for schedule in schedules]
    for constraint, atom in _bare_relations(model):
        names = sorted(set(ir.atom_signals(atom)))
        seen = void = 0
        absent: dict[str, int] = dict.fromkeys(names, 0)
        for intervals in every:
            present = [name for name in names if intervals.get(name)]
            if not present:
                continue
            seen += 1
            if evaluate_expr(constraint.expr, intervals, ticks) is None:
                void += 1
                for name in names:
                    absent[name] += name not in present
        if seen < MIN_SEEN or void <= VOID_SHARE * seen:
            continue
        partner = max(names, key=lambda name: absent[name])
        other = next(name for name in names if name != partner)
        text = expr_text(constraint.expr)
        found.append(
            Diagnostic(
                "N407",
                f"constraint {constraint.id!r} is void in {void} of {seen} sampled {duration:g} s timelines that "
                f"show {other!r} or {partner!r} (mostly because {partner!r} is absent); if {other!r} needs "
                f"{partner!r}, write 'exists({partner}) and {text}'",
                constraint.span,
            )
        )
    return found


def sampled_void_relations(model: ir.Model, duration: float, seed: int = 0) -> list[Diagnostic]:
    """:func:`void_relations` over :data:`SAMPLES` timelines of the walk (none when it fails)."""
    if not any(True for _ in _bare_relations(model)):
        return []
    from mse.diagnostics import MseError
    from mse.solve.greedy.solver import GreedySolver
    from mse.solve.protocol import SolveRequest

    try:
        result = GreedySolver().solve(model, SolveRequest(duration=duration, seed=seed, count=SAMPLES))
    except MseError:  # no timeline: the infeasibility rules speak for the set
        return []
    return void_relations(model, [solution.schedule for solution in result.solutions], duration)

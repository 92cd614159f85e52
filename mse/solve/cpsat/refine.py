"""Gibbs sweeps that move a CP-SAT timeline towards the exact target distribution.

Perturb-and-MAP (:mod:`mse.solve.cpsat.objective`) is exact for one signal on its own but
biased for signals that constraints couple: a constraint that needs a coincidence (``equal
(start(a), start(b), 0.3)``) costs little to a maximiser, which moves ``a`` onto ``b``,
while under the prior the coincidence is rare, so that the target — the prior conditioned on
consistency — seldom shows both.  The sweeps correct that: in turn, each signal's
occurrences are replaced by a fresh draw of that signal from the prior (its whole timeline:
presence, start and length, or the renewal process of a repetitive signal), and the proposal
is kept iff the timeline stays consistent.  With the prior as proposal, the Metropolis-
Hastings ratio is exactly "consistent or not", so the target is the chain's stationary
distribution: each sweep can only bring the timeline closer to it, starting from the
consistent timeline CP-SAT found.  Only the constraints that name the moved signal and its
exclusive modality are re-checked (the others cannot change).
"""

from __future__ import annotations

import random
from collections.abc import Sequence

from mse.ir import model as ir
from mse.ir.evaluate import constraint_status
from mse.ir.schedule import Occurrence, Schedule
from mse.solve.cpsat.prior import draw_once, renewal_starts


def _draw(signal: ir.Signal, duration: int, rng: random.Random) -> list[tuple[int, int]]:
    """The occurrences of ``signal`` alone over the whole timeline, drawn from the prior."""
    if signal.repetitive:
        return renewal_starts(signal, duration, 0, duration, signal.max_occurrences, rng)
    drawn = draw_once(signal, duration, rng)
    return [] if drawn is None else [drawn]


def refine(model: ir.Model, schedule: Schedule, rng: random.Random, *, violate: bool = False,
           keep: Sequence[str] = (), require: Sequence[str] = (), forbid: Sequence[str] = (),
           sweeps: int = 12) -> Schedule:
    """``schedule`` (consistent; with ``violate``, violating some constraint) after ``sweeps``
    Gibbs sweeps; ``keep`` signals (pinned) never move, the request stays met."""
    duration = schedule.duration
    intervals: dict[str, list[tuple[int, int]]] = {}
    for occurrence in schedule.occurrences:
        intervals.setdefault(occurrence.signal, []).append((occurrence.start, occurrence.stop))
    touching: dict[str, list[ir.Constraint]] = {}
    for constraint in model.constraints:
        for name in ir.mentioned_signals(constraint.expr):
            touching.setdefault(name, []).append(constraint)
    violated = {c.id for c in model.constraints if constraint_status(c, intervals, duration) is False}
    exclusive = model.exclusive_modalities
    movable = [s for s in model.signals if s.id not in set(keep)]
    required, forbidden = set(require), set(forbid)
    for _ in range(sweeps):
        for signal in rng.sample(movable, len(movable)):
            proposal = _draw(signal, duration, rng)
            name = signal.id
            if (name in required and not proposal) or (name in forbidden and proposal):
                continue
            if proposal == intervals.get(name, []):
                continue
            if proposal and signal.modality in exclusive and any(
                    a < stop and start < b
                    for other in model.signals if other.id != name and other.modality == signal.modality
                    for a, b in intervals.get(other.id, ()) for start, stop in proposal):
                continue
            before = intervals.get(name)
            if proposal:
                intervals[name] = proposal
            else:
                intervals.pop(name, None)
            changed = {c.id: constraint_status(c, intervals, duration) is False for c in touching.get(name, ())}
            now = (violated - set(changed)) | {key for key, bad in changed.items() if bad}
            if (violate and now) or (not violate and not now):
                violated = now
                continue
            if before is None:
                intervals.pop(name, None)
            else:
                intervals[name] = before
    return Schedule.of(duration, (Occurrence(a, b, name) for name, spans in intervals.items() for a, b in spans))

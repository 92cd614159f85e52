"""How many occurrence slots each signal needs (shared by the CP-SAT and csp backends).

No solver is imported here.  Two bounds matter:

* the *semantic limit*: what the semantics allows — 1 without repetitivity, else
  ``max_occurrences`` or ``floor(D / min_duration)`` (occurrences of one signal never
  overlap, so no more fit);
* the *witness bound*: what an existence proof needs.  Take any consistent timeline and
  keep, for every signal, one occurrence plus, for every relational atom that is false,
  the occurrences of one combination that falsifies it.  True atoms stay true (fewer
  combinations), false atoms keep their witness, presence (so every unknown atom, every
  ``exists`` and every instantiation) is unchanged, and fewer occurrences never break an
  occurrence rule.  So a signal needs at most ``max(1, atoms naming it) + pins on it``
  slots: with that many slots "infeasible" is a real proof.

Sampling uses ``min(semantic limit, SAMPLE_SLOTS)`` slots (a repetitive signal can recur
a few times) and falls back to the witness bound before claiming a proof.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Mapping

from mse.ir import model as ir
from mse.ir.schedule import to_ticks

#: Slots per repetitive signal when sampling (variety without blowing up the model).
SAMPLE_SLOTS = 3
#: Absolute cap on slots of one signal, whatever the bounds say (documented in docs/solvers.md).
MAX_SLOTS = 24


def length_bounds(signal: ir.Signal, duration: int) -> tuple[int, int]:
    """Smallest and largest length of one occurrence in ticks (start < stop, so >= 1)."""
    low = max(1, to_ticks(signal.min_duration))
    high = duration if signal.max_duration is None else min(duration, to_ticks(signal.max_duration))
    return low, high


def semantic_limit(signal: ir.Signal, duration: int, step: int = 1) -> int:
    """Most occurrences the semantics allows in ``duration`` ticks (0 when none fits).

    ``step`` > 1 counts occurrences on a grid of that many ticks (csp and grid enumeration)."""
    low, high = length_bounds(signal, duration)
    if step > 1:
        low = -(-low // step) * step
        high = high // step * step
    if low > high or low > duration:
        return 0
    if not signal.repetitive:
        return 1
    fit = duration // low
    return fit if signal.max_occurrences is None else min(fit, signal.max_occurrences)


def atom_mentions(model: ir.Model) -> Counter[str]:
    """Per signal, the number of relational atoms (in all constraints) that name it."""
    counts: Counter[str] = Counter()
    for constraint in model.constraints:
        for node in ir.walk(constraint.expr):
            if isinstance(node, ir.Relation | ir.Compare):
                counts.update(set(ir.atom_signals(node)))
    return counts


def slot_counts(
    model: ir.Model,
    duration: int,
    *,
    complete: bool,
    pins: Iterable[str] = (),
    step: int = 1,
    exact: bool = False,
) -> Mapping[str, int]:
    """Slots per signal: ``complete`` uses the witness bound (proofs), else SAMPLE_SLOTS;
    ``exact`` uses the semantic limit itself (enumeration, where counts must agree)."""
    mentions = atom_mentions(model)
    pinned = Counter(pins)
    counts: dict[str, int] = {}
    for signal in model.signals:
        limit = semantic_limit(signal, duration, step)
        if exact:
            wanted = limit
        elif complete:
            wanted = max(1, mentions[signal.id]) + pinned[signal.id]
        else:
            wanted = max(SAMPLE_SLOTS, pinned[signal.id])
        counts[signal.id] = min(limit, wanted, MAX_SLOTS)
    return counts


def is_complete(
    model: ir.Model, duration: int, counts: Mapping[str, int], pins: Iterable[str] = ()
) -> bool:
    """True when ``counts`` reach the (uncapped) witness bound of every signal, so that
    "infeasible" with these slots is a proof (only MAX_SLOTS can make this false)."""
    mentions = atom_mentions(model)
    pinned = Counter(pins)
    return all(
        counts[s.id] >= min(semantic_limit(s, duration), max(1, mentions[s.id]) + pinned[s.id])
        for s in model.signals
    )

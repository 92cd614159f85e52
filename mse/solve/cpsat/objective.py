"""Objectives of the CP-SAT backend: perturb-and-MAP by default, others on request.

Perturb-and-MAP (Papandreou & Yuille 2011): the MAP assignment of a model's
log-probabilities plus independent Gumbel noise on every choice is a sample of the model.
Each occurrence slot chooses between *absent* and *present, starting in time bin b*
(B bins over the timeline).  A signal's probability at time t is the straight line from
probability_start (t = 0) to probability_end (t = D); with p_b its value at the middle of
bin b and p̄ the mean over the bins, the slot's log-probabilities are
``log(1 - p̄)`` for absent and ``log(p_b / B)`` for bin b: present with probability p̄,
starting in a bin in proportion to the profile.  Adding seeded Gumbel noise to each
choice and maximising gives a sample that follows the profiles; "likely" drops the
noise (the MAP timeline), "random" drops the probabilities.  Within a bin, seeded target
start times and lengths, given as solution hints, spread the timelines further at no
cost to the search.

Further occurrences of a repetitive signal pay REPEAT_COST.  Coefficients are
multiplied by SCALE and rounded to integers.
"""

from __future__ import annotations

import math
import random
from collections.abc import Sequence

from mse.ir.schedule import Schedule
from mse.solve.bounds import length_bounds
from mse.solve.cpsat.encode import Encoding, Slot

SCALE = 1000
#: Probabilities are clipped away from 0 and 1 so that logarithms stay finite.
EPSILON = 0.01
#: Extra log-probability cost of each further occurrence of a repetitive signal.
REPEAT_COST = 1.5
#: Bins of start times per timeline (fewer for short timelines: at least 0.5 s each).
MAX_BINS = 8
#: Weight of one slot's difference (presence, or D ticks of start) for --diverse, in SCALE units.
DIVERSITY_WEIGHT = 3


def clip(probability: float) -> float:
    return min(1.0 - EPSILON, max(EPSILON, probability))


def gumbel(rng: random.Random) -> float:
    u = min(1.0 - 1e-12, max(1e-12, rng.random()))
    return -math.log(-math.log(u))


def _bins(duration: int) -> list[tuple[int, int]]:
    count = max(1, min(MAX_BINS, duration // 500))
    edges = [duration * b // count for b in range(count + 1)]
    return [(edges[b], edges[b + 1]) for b in range(count)]


def _choice_terms(
    enc: Encoding, slot: Slot, first: float, last: float, rng: random.Random, *, profile: bool, noise: bool
) -> list[object]:
    """Terms of one slot's choice among absent and the start bins (absent is the baseline).

    One literal per bin (an element constraint on a bin index was measured slower at
    p95).  The slot's own best choice is hinted (with a seeded start inside the bin):
    when the constraints allow it, that hint is already optimal and the search ends at
    once."""
    bins = _bins(enc.duration)
    middles = [clip(first + (last - first) * ((lo + hi) / 2) / max(1, enc.duration)) for lo, hi in bins]
    mean = sum(middles) / len(middles)
    absent_score = (math.log(1.0 - mean) if profile else 0.0) + (gumbel(rng) if noise else 0.0)
    terms: list[object] = []
    choices = []
    best: tuple[float, int, int] = (0.0, -1, -1)
    for (lo, hi), probability in zip(bins, middles, strict=True):
        score = (math.log(probability / len(bins)) if profile else 0.0) + (gumbel(rng) if noise else 0.0)
        score -= absent_score + REPEAT_COST * slot.index
        chosen = enc.cp.new_bool_var("")
        enc.cp.add(slot.start >= lo).only_enforce_if(chosen)
        enc.cp.add(slot.start <= hi - 1).only_enforce_if(chosen)
        choices.append(chosen)
        terms.append(round(SCALE * score) * chosen)
        if score > best[0]:
            best = (score, lo, hi)
    enc.cp.add(sum(choices) == slot.present)
    _hint(enc, slot, rng, best[1], best[2])
    return terms


def _hint(enc: Encoding, slot: Slot, rng: random.Random, lo: int, hi: int) -> None:
    """Hint ``slot`` present with a seeded start in [lo, hi) (absent when lo < 0)."""
    signal = enc.model.signal(slot.signal)
    low, high = length_bounds(signal, enc.duration)
    if lo < 0 or lo + low > enc.duration:
        enc.cp.add_hint(slot.present, False)
        return
    start = rng.randint(lo, max(lo, min(hi - 1, enc.duration - low)))
    length = rng.randint(low, max(low, min(high, enc.duration - start)))
    enc.cp.add_hint(slot.present, True)
    enc.cp.add_hint(slot.start, start)
    enc.cp.add_hint(slot.length, length)
    enc.cp.add_hint(slot.stop, start + length)


def objective_terms(enc: Encoding, objective: str | None, seed: int) -> list[object]:
    """The terms of ``objective`` (None: perturb-and-MAP), to be maximised."""
    rng = random.Random(seed)
    terms: list[object] = []
    if objective in (None, "likely", "random"):
        noise, profile = objective != "likely", objective != "random"
        for signal in enc.model.signals:
            for slot in enc.slots[signal.id]:
                terms.extend(_choice_terms(enc, slot, signal.probability_start, signal.probability_end,
                                           rng, profile=profile, noise=noise))
        return terms
    slot_total = sum(len(slots) for slots in enc.slots.values())
    # Seeded tie-breaks (presence and position) that together never outweigh one signal.
    big = SCALE * (2 * slot_total + 1)
    sign = 1 if objective == "most-signals" else -1
    for signal in enc.model.signals:
        occurs = enc.occurs[signal.id]
        if not isinstance(occurs, bool):
            terms.append(sign * big * occurs)
        for slot in enc.slots[signal.id]:
            terms.append(rng.randint(0, SCALE) * slot.present)
            _hint(enc, slot, rng, 0 if sign > 0 else -1, enc.duration)
    return terms


def set_objective(
    enc: Encoding, objective: str | None, seed: int, previous: Sequence[Schedule] = ()
) -> None:
    """Install ``objective``; with ``previous`` schedules, add the diversity reward."""
    terms = objective_terms(enc, objective, seed)
    if previous:
        terms.extend(_diversity_terms(enc, previous))
    enc.cp.maximize(sum(terms))  # type: ignore[arg-type]


def _diversity_terms(enc: Encoding, previous: Sequence[Schedule]) -> list[object]:
    """Reward the smallest distance to the ``previous`` schedules (and, less, their sum).

    Distance: per slot, D if its presence differs, plus |start - previous start| if both
    are present; a slot is compared with the occurrence of the same rank."""
    duration = max(1, enc.duration)
    slot_total = max(1, sum(len(s) for s in enc.slots.values()))
    distances = []
    for schedule in previous:
        by_signal = schedule.by_signal()
        parts: list[object] = []
        for signal_id, slots in enc.slots.items():
            before = sorted(by_signal.get(signal_id, []))
            for slot in slots:
                if slot.index < len(before):
                    parts.append(duration * (1 - slot.present))
                    moved = enc.cp.new_int_var(0, duration, "")
                    enc.cp.add_abs_equality(moved, slot.start - before[slot.index].start)
                    parts.append(moved)
                else:
                    parts.append(duration * slot.present)
        total = enc.cp.new_int_var(0, 2 * duration * slot_total, "")
        enc.cp.add(total == sum(parts))  # type: ignore[arg-type]
        distances.append(total)
    smallest = enc.cp.new_int_var(0, 2 * duration * slot_total, "")
    for distance in distances:
        enc.cp.add(smallest <= distance)
    # Per tick of distance: DIVERSITY_WEIGHT * SCALE / D, as an integer >= 1.
    per_tick = max(1, round(DIVERSITY_WEIGHT * SCALE / duration))
    return [2 * per_tick * smallest, *(per_tick * d for d in distances)]

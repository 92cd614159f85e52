"""The walk over the time stamps of one attempt (paper §4.3), on an :class:`Attempt`.

At each stamp t_j the candidates are the owed signals (first, each with the larger of the
table's probability and 1 / the stamps left before its deadline) and the signals whose next
candidacy falls at this stamp (drawn ahead from the cumulative hazard, :func:`schedule`), in
random order.  Each is tried once per state with :meth:`Attempt.try_place`; a placement that
opens an owed signal's window tries that one again at once.  Split from engine.py,
which holds the checks and the bookkeeping.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable
from typing import TYPE_CHECKING

from mse.ir.schedule import Occurrence
from mse.solve.greedy.plan import SignalPlan

if TYPE_CHECKING:
    from mse.solve.greedy.engine import Attempt

# bound once: the walk calls them tens of thousands of times per second
_log = math.log
_bisect_right = bisect.bisect_right


def _shuffle(getrandbits: Callable[[int], int], items: list[SignalPlan]) -> None:
    """``random.Random.shuffle``, written out with the same draws (CPython's Fisher-Yates over
    ``_randbelow_with_getrandbits``), so the same order: it saves two calls per element on
    the hot path, and pins the order to this code rather than to the standard library."""
    for i in range(len(items) - 1, 0, -1):
        bound = i + 1
        bits = bound.bit_length()
        j = getrandbits(bits)
        while j >= bound:
            j = getrandbits(bits)
        items[i], items[j] = items[j], items[i]


def walk(attempt: Attempt) -> list[Occurrence]:
    """The occurrences of one attempt (:class:`Doomed` when an obligation cannot be met)."""
    plan, rng = attempt.plan, attempt.rng
    # Bound once (the same objects all attempt long): this loop is the hot path.
    dead, buckets, occurrences = attempt.dead, attempt.buckets, attempt.occurrences
    try_place = attempt.try_place
    random_draw, cumulative_of, last_stamp = rng.random, plan.cumulative, len(buckets)
    for signal in plan.signals:
        if signal.id not in dead and last_stamp:
            # schedule(signal, 0), inlined: once per signal and attempt
            cumulative = cumulative_of[signal.index]
            after = _bisect_right(cumulative, cumulative[0] - _log(1.0 - random_draw()), 1)
            if after <= last_stamp:
                buckets[after - 1].append(signal)
    if plan.initial_owing:  # what an empty timeline violates, computed once per plan
        attempt.owing = set(plan.initial_owing)
    if plan.initial_owing or attempt.require:
        attempt.refresh_latest()
    stamps = plan.stamps
    for j in range(len(stamps) - 1):
        low, high = stamps[j], stamps[j + 1] - 1
        if high < low:
            continue
        attempt.stamp_low = low
        queue: list[SignalPlan] = []
        if attempt.latest:
            if any(latest < low for latest in attempt.latest.values()):
                attempt.refresh_latest()
            row = plan.table[j]
            for name in sorted(attempt.latest):
                remaining = plan.stamp_of(attempt.latest[name]) - j + 1
                if remaining >= 1 and rng.random() < max(row[plan.by_id[name].index], 1 / remaining):
                    queue.append(plan.by_id[name])
        proposals = [s for s in buckets[j] if s.id not in dead]
        if not proposals and not queue:
            continue
        if len(proposals) > 1:
            _shuffle(rng.getrandbits, proposals)
        queue.extend(proposals)
        # Each signal is tried once per stamp and state: a placement may open the window of
        # a signal tried before it (an owed partner), which is then tried again at once.
        tried: dict[str, int] = {}
        position = 0
        while position < len(queue):
            signal = queue[position]
            position += 1
            version = len(occurrences)
            if tried.get(signal.id) == version:
                continue
            tried[signal.id] = version
            frontier = attempt.frontier
            if try_place(signal, low if low > frontier else frontier, high) and attempt.latest:
                version += 1
                urgent = [
                    plan.by_id[n] for n, t in sorted(attempt.latest.items()) if t <= high and tried.get(n) != version
                ]
                queue[position:position] = urgent
        for signal in proposals:
            if signal.id not in dead:
                schedule(attempt, signal, j + 1)
    return occurrences


def schedule(attempt: Attempt, signal: SignalPlan, first: int) -> None:
    """Put ``signal`` in the bucket of its next candidacy at stamp ``first`` or later."""
    cumulative = attempt.plan.cumulative[signal.index]
    stamps = len(cumulative) - 1
    if first >= stamps:
        return
    target = cumulative[first] - _log(1.0 - attempt.rng.random())
    after = _bisect_right(cumulative, target, first + 1)
    if after <= stamps:
        attempt.buckets[after - 1].append(signal)

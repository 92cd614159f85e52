"""The walk over the time stamps (paper §4.3) on an :class:`Attempt`, with checkpoints.

At each stamp t_j the candidates are the owed signals (first, each with the probability
:func:`payers_pay` gives: certain at its deadline when it alone can pay), the signals others
need (:func:`enabling`) and the signals whose next candidacy falls at this stamp (drawn ahead
from the cumulative hazard, :func:`schedule`), in the order of the starts drawn for them.
Each is tried once per state with :meth:`Attempt.try_place`; a placement that
opens an owed signal's window tries that one again at once.

The state at the start of every stamp is a *checkpoint*.  When the walk paints itself into a
corner (an obligation can no longer be met, or the end is reached with a debt), it goes back
1, 2, 4, ... stamps (doubling on repeated failures, then starting over at 1) and walks on from
there with fresh draws: bounded backtracking, ``budget`` failures without getting further than
before, then :class:`OutOfBudget`.  The first failure instead sends the walk back to its start
*careful* (:data:`CAREFUL_AFTER`, ``Attempt.careful``: optional placements may add no debt).
A stamp where nothing is owed is *settled*: the occurrences placed so far are, alone, a
consistent timeline, so the walk can always be completed from there (by adding nothing).
When streaming, every settled stamp *commits*: the occurrences before it are handed out and
the walk never goes back past it (docs/sampler.md, "Streaming").
"""

from __future__ import annotations

import bisect
import math
from collections import Counter
from collections.abc import Generator
from typing import TYPE_CHECKING

from mse.ir.schedule import Occurrence
from mse.solve.greedy.debts import Doomed
from mse.solve.greedy.plan import Plan, SignalPlan, prior_starts_in

if TYPE_CHECKING:
    from mse.solve.greedy.engine import Attempt

# bound once: the walk calls them tens of thousands of times per second
_log = math.log
_bisect_right = bisect.bisect_right

#: A walk fails for good after ``budget`` failures without getting further than before, or
#: after this many times ``budget + 1`` failures in all.
TOTAL_FACTOR = 2
#: Partial checks a walk may make, per stamp and per signal or constraint of the model, plus a
#: constant; past it the walk gives up (a deterministic bound on effort: the default solver
#: then falls back to CP-SAT).  Ordinary walks use a few percent of it.
WORK_PER_STAMP = 5
WORK_BASE = 5_000
#: After this many failures the walk starts over from its beginning (or its last commit)
#: *careful*: a candidate that is not owed may not add a debt (Attempt.careful).
CAREFUL_AFTER = 1
#: After this many failures of careful walks, the walk starts over, not careful, for good.
CAREFUL_TRIES = 10
#: A walk whose empty timeline already owes this many debts (mandatory signals, ``--require``)
#: is careful from the start: taking optional debts on top of them rarely ends well (half the
#: walks of the planted 200-signal sets of ``bench/speed/sample.py --scale``, which owe 7-25, failed
#: after their backtracks).  The bundled and Greta sets owe at most one.
CAREFUL_DEBTS = 4


class OutOfBudget(Exception):
    """The walk failed ``budget + 1`` times: ``unmet`` counts why (constraint ids, requires)."""

    def __init__(self, unmet: Counter[str]) -> None:
        super().__init__(", ".join(unmet))
        self.unmet = unmet


class Checkpoint:
    __slots__ = ("frontier", "kept", "owing", "stamp")

    def __init__(self, stamp: int, kept: int, frontier: int, owing: frozenset[str]) -> None:
        self.stamp = stamp  # the stamp the walk resumes at
        self.kept = kept  # occurrences of Attempt.occurrences kept
        self.frontier = frontier
        self.owing = owing


def walk(attempt: Attempt, budget: int = 0, backtracks: list[int] | None = None) -> list[Occurrence]:
    """The occurrences of one walk, backtracking at most ``budget`` times without progress
    (:class:`OutOfBudget` past that)."""
    steps = walk_steps(attempt, budget, stream=False, backtracks=backtracks)
    while True:
        try:
            next(steps)
        except StopIteration as done:
            result: list[Occurrence] = done.value
            return result


def walk_steps(
    attempt: Attempt, budget: int, *, stream: bool, backtracks: list[int] | None = None
) -> Generator[list[Occurrence], None, list[Occurrence]]:
    """The walk as a generator.  With ``stream``, yields the occurrences committed at each
    settled stamp (in start order) and returns the last ones; when the budget runs out after
    a commit, it ends the timeline at the last commit (consistent) instead of failing.
    ``backtracks`` (a one-element list) counts the backtracks, for the caller's statistics."""
    plan = attempt.plan
    last_stamp = len(plan.stamps) - 1
    attempt.owing = set(plan.initial_owing)  # what an empty timeline violates, once per plan
    if len(plan.initial_owing) + len(attempt.require) >= CAREFUL_DEBTS:
        attempt.careful = True  # many debts from the start: careful at once (see CAREFUL_DEBTS)
    start_candidacies(attempt, 0)
    if plan.initial_owing or attempt.require:
        attempt.initial_debts()  # Doomed here: no walk can pay (the caller falls back)
    # checkpoints[i]: the state at the start of stamp checkpoints[i].stamp (increasing); the
    # first one is the start of the walk or, when streaming, the last commit.
    checkpoints: list[Checkpoint] = []
    committed = False  # checkpoints[0] was committed (streaming): never go back past it
    unmet: Counter[str] = Counter()
    failures = total = 0  # since the walk last got further than ever before; in all
    furthest = -1
    reach = 0  # the next backtrack goes back 2**reach stamps
    work_limit = WORK_PER_STAMP * (len(plan.signals) + len(plan.constraints)) * last_stamp + WORK_BASE
    j = 0
    careful_failures = 0  # failures of careful walks
    resume: Checkpoint | None = None
    while True:
        try:
            if resume is not None:
                j, checkpoint, resume = resume.stamp, resume, None
                attempt.truncate(checkpoint.kept, checkpoint.frontier, checkpoint.owing)
                attempt.stamp_low = plan.stamps[j]
                start_candidacies(attempt, j)
                if attempt.owing or attempt.require:
                    attempt.refresh_latest()
            while j < last_stamp:
                if not checkpoints or checkpoints[-1].stamp < j:
                    if stream and attempt.occurrences and not attempt.owing and attempt.settled():
                        yield attempt.occurrences[:]
                        del attempt.occurrences[:]
                        checkpoints, committed = [], True
                    checkpoints.append(Checkpoint(j, len(attempt.occurrences), attempt.frontier,
                                                  frozenset(attempt.owing)))
                    if j > furthest:
                        furthest, failures = j, 0
                walk_stamp(attempt, j)
                j += 1
                if attempt.work > work_limit:
                    unmet["(work limit)"] += 1
                    if committed:
                        attempt.truncate(0, checkpoints[0].frontier, frozenset())
                        return attempt.occurrences  # the last commit ends the timeline
                    raise OutOfBudget(unmet)
            if not attempt.settled():
                raise Doomed(next(iter(sorted(attempt.owing)), "") or "require "
                             + ", ".join(sorted(n for n in attempt.require if not attempt.env.get(n))))
            return attempt.occurrences
        except Doomed as doomed:
            unmet[str(doomed)] += 1
            failures += 1
            total += 1
            if backtracks is not None:
                backtracks[0] += 1
            if failures > budget or total > TOTAL_FACTOR * (budget + 1):
                if committed:
                    attempt.truncate(0, checkpoints[0].frontier, frozenset())
                    return attempt.occurrences  # the last commit ends the timeline
                raise OutOfBudget(unmet) from None
            # Go back 1, 2, 4, ... stamps on repeated failures, until the first checkpoint,
            # then start over at 1: a debt is usually made unpayable by a recent choice,
            # sometimes by an old one.
            target = j - (1 << reach)
            index = max(0, bisect.bisect_right([c.stamp for c in checkpoints], target) - 1)
            if attempt.careful:
                careful_failures += 1
                if careful_failures == CAREFUL_TRIES:
                    # Careful does not pay here (a debt whose payment needs an optional
                    # signal that owes something): walk again from the start as the paper.
                    index, attempt.careful = 0, False
            elif total == CAREFUL_AFTER and not careful_failures:
                # The debt was made unpayable by optional choices, often early ones that
                # backtracking 1, 2, 4, ... stamps draws again (an optional signal whose
                # implication owes a signal excluding a required one; repeated partners
                # closing a required signal's window).  Walk again from the start keeping
                # the owed signals' room: optional placements may add no debt.
                index, attempt.careful = 0, True
            reach = 0 if index == 0 else reach + 1
            resume = checkpoints[index]
            del checkpoints[index + 1:]


def walk_stamp(attempt: Attempt, j: int) -> None:
    """Every candidate of stamp ``j`` (raises :class:`Doomed` when a deadline passed unpaid)."""
    plan, rng = attempt.plan, attempt.rng
    dead, try_place = attempt.dead, attempt.try_place
    stamps = plan.stamps
    low, high = stamps[j], stamps[j + 1] - 1
    if high < low:
        return
    attempt.stamp_low = low
    queue: list[SignalPlan] = []
    owed: set[str] = set()  # drawn above with the debt's probability: not a second time below
    sharing: set[str] = set()  # those of them not due in this stamp (Attempt.sharing)
    careful = attempt.careful
    if attempt.latest:
        if any(latest < low for latest in attempt.latest.values()):
            attempt.refresh_latest(expired_only=True)
        row = plan.table[j]
        pays = payers_pay(attempt, j)
        for name in sorted(attempt.latest):
            signal = plan.by_id[name]
            due = plan.stamp_of(attempt.latest[name])
            if due < j:
                continue
            chance = pays.get(name)
            if chance is None:
                # It alone can pay: due in this stamp with the profile's share of what is left
                # before the deadline (certain at the deadline; evenly spread when the profile
                # is 0 there), on top of its own candidacy (this only moves its start earlier:
                # it must occur; it leaves the others room, docs/sampler.md "Signals that must
                # occur").
                masses = plan.masses[signal.index]
                left = masses[due + 1] - masses[j]
                share = max(row[signal.index], (masses[j + 1] - masses[j]) / left if left > 0 else 1 / (due - j + 1))
            else:
                # One of several that may pay: a candidate with the prior's probability given
                # that the debt is paid, the table's hazard over the probability that the prior
                # alone starts one of the payers before its deadline, and only so (not its own
                # candidacy as well).  Forcing each as if it were the only one over-placed the
                # payers of a disjunction (docs/sampler.md, "Owed signals").
                owed.add(name)
                if due > j:
                    sharing.add(name)
                share = row[signal.index] / chance if chance > 0 else 1 / (due - j + 1)
            # careful (after failures): every owed signal is a candidate at every stamp
            if rng.random() < share or careful:
                queue.append(signal)
    attempt.sharing = frozenset(sharing)
    if plan.enables:
        queue.extend(enabling(attempt, j))
    bucket = attempt.buckets[j]
    if not bucket and not queue:
        return
    proposals = [s for s in bucket if s.id not in dead]
    bucket.clear()
    # Each candidate nothing owes gets its place in the stamp now (Attempt.offsets: where the
    # prior starts it) and they are tried in that order, so that the frontier a placement
    # moves never pushes a later one's start (tried in a random order, a candidate placed
    # late in the stamp delayed the others: three unconstrained repetitive signals lost 4 %
    # of their starts).
    offsets = attempt.offsets
    offsets.clear()
    if proposals:
        random = rng.random
        for signal in proposals:
            offsets[signal.id] = random()
        if len(proposals) > 1:
            proposals.sort(key=lambda signal: offsets[signal.id])
    # An owed signal's own candidacy is the one drawn above (its prior probability given the
    # debt is paid): its bucket's would be a second chance in the stamp.
    queue.extend([s for s in proposals if s.id not in owed] if owed else proposals)
    # Each signal is tried once per stamp and state: a placement may open the window of
    # a signal tried before it (an owed partner), which is then tried again at once.
    tried: dict[str, int] = {}
    placed: set[str] = set()
    position = 0
    while position < len(queue):
        signal = queue[position]
        position += 1
        version = attempt.placements
        if tried.get(signal.id) == version:
            continue
        tried[signal.id] = version
        frontier = attempt.frontier
        if try_place(signal, low if low > frontier else frontier, high):
            placed.add(signal.id)
            if attempt.latest:
                version += 1
                urgent = [
                    plan.by_id[n] for n, t in sorted(attempt.latest.items()) if t <= high and tried.get(n) != version
                ]
                queue[position:position] = urgent
    for signal in proposals:
        if signal.id in dead:
            continue
        if signal.id in placed:
            # free again at its stop: a repetitive signal's next start is drawn from there
            schedule_from(attempt, signal, attempt.last_stop[signal.id], j + 1)
        else:
            schedule(attempt, signal, j + 1)


def enabling(attempt: Attempt, j: int) -> list[SignalPlan]:
    """Extra candidacies at stamp ``j`` of the once-only signals that others must follow
    (``exists(s1) and precedes(s1, s2)``: ``Plan.enables``), so that one is a candidate with
    its table's probability ``h`` times the gain ``B`` its start brings: the target keeps
    the prior's timelines where each signal needing it is absent or starts after it, so a
    start now weighs ``g = prod (1 - q_y + p_y) / (1 - q_y)`` against never (``q_y``: the
    prior's probability that ``y`` starts from now on, ``p_y``: after this one's shortest
    length), and ``B = g / (1 - l + l g)`` against starting later (``l``: the prior's
    probability that it does).  Time-ordered, the walk drew it at its prior rate, and the
    signals needing it occurred less often than the target has them (docs/sampler.md)."""
    plan, env, dead, count = attempt.plan, attempt.env, attempt.dead, attempt.count
    memo = plan.enabling_memo
    found: list[SignalPlan] = []
    for position, (signal, followers) in enumerate(plan.enables):
        if signal.id in dead or env.get(signal.id):
            continue
        free = tuple(other.index for other in followers if other.id not in dead and not count.get(other.id, 0))
        key = (position, j, free)
        extra = memo.get(key)
        if extra is None:
            extra = memo[key] = _enabling_extra(plan, j, signal, [plan.signals[i] for i in free])
        if extra > 0.0 and attempt.rng.random() < extra:
            found.append(signal)
    return found


def _enabling_extra(plan: Plan, j: int, signal: SignalPlan, followers: list[SignalPlan]) -> float:
    """The probability of :func:`enabling`'s extra candidacy of ``signal`` at stamp ``j``
    with ``followers`` still free (it depends on nothing else: cached per plan)."""
    hazard = plan.table[j][signal.index]
    if hazard <= 0.0 or hazard >= 1.0:
        return 0.0
    low, duration, n = plan.stamps[j], plan.duration, len(plan.stamps) - 1
    # where it would be: from this stamp, for its mean length
    box = (low, low, low + signal.shortest, low + (signal.shortest + signal.longest) // 2)
    gain = 1.0
    for other in followers:
        q = prior_starts_in(other, ((low, duration - other.shortest),), low, duration)
        if q >= 1.0 - 1e-9:
            continue
        # after its shortest length if it must come after it, else from its start on
        first = low + (signal.shortest if signal.id in plan.needs_before[other.id] else 0)
        last = duration - other.shortest
        for partner, rules in plan.partner_bounds[other.id]:
            if partner == signal.id:
                for index, delta, upper in rules:
                    if upper:
                        last = min(last, box[index + 1] + delta)
                    else:
                        first = max(first, box[index] + delta)
        if first > last or first >= duration:
            continue
        opened = prior_starts_in(other, ((first, last),), low, duration)
        gain *= (1.0 - q + opened) / (1.0 - q)
    if gain <= 1.0:
        return 0.0
    own = plan.cumulative[signal.index]
    later = 1.0 - math.exp(own[j + 1] - own[n])
    boost = gain / (1.0 - later + later * gain)
    return hazard * (boost - 1.0) / (1.0 - hazard)


def payers_pay(attempt: Attempt, j: int) -> dict[str, float]:
    """Per owed signal that shares its debts with other payers, the probability that the
    prior alone starts one of the payers from stamp ``j`` on, each before its deadline: the
    payers of an owing constraint are the owed signals it mentions; with several debts, the
    least likely to be paid counts.  Left out: the owed signals that are the sole payer of a
    debt or on no owing constraint (a prerequisite, a ``--require``): they must occur."""
    plan, latest = attempt.plan, attempt.latest
    alone: dict[str, float] = {}
    for name, deadline in latest.items():
        due = plan.stamp_of(deadline)
        cumulative = plan.cumulative[plan.by_id[name].index]
        alone[name] = 1.0 - math.exp(cumulative[j] - cumulative[due + 1]) if due >= j else 0.0
    found: dict[str, float] = {}
    single: set[str] = set()  # the sole payer of some debt: it must occur
    for cid in attempt.owing:
        payers = [name for name in plan.by_constraint_id[cid].mentioned if name in alone]
        if len(payers) == 1:
            single.add(payers[0])
            continue
        missed = 1.0
        for name in payers:
            missed *= 1.0 - alone[name]
        for name in payers:
            if 1.0 - missed < found.get(name, 2.0):
                found[name] = 1.0 - missed
    for name in single:
        found.pop(name, None)
    return found


def start_candidacies(attempt: Attempt, first: int) -> None:
    """Draw every available signal's next candidacy from stamp ``first`` on (walk start, and
    after a backtrack: the draws before were taken back with the occurrences)."""
    for bucket in attempt.buckets[first:]:
        bucket.clear()
    tick = attempt.plan.stamps[first]
    for signal in attempt.plan.signals:
        if signal.id in attempt.dead:
            continue
        stop = attempt.last_stop.get(signal.id)
        if stop is not None and stop > tick:
            schedule_from(attempt, signal, stop, first)
        else:
            schedule(attempt, signal, first)


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


def schedule_from(attempt: Attempt, signal: SignalPlan, tick: int, first: int) -> None:
    """Put ``signal`` in the bucket of its next candidacy, counting its hazard from ``tick``
    (the cumulative hazard grows linearly inside a stamp), at stamp ``first`` or later."""
    plan = attempt.plan
    cumulative = plan.cumulative[signal.index]
    stamps = len(cumulative) - 1
    k = plan.stamp_of(min(tick, plan.duration - 1))
    if k >= stamps:
        return
    length = plan.stamps[k + 1] - plan.stamps[k]
    fraction = (tick - plan.stamps[k]) / length if length else 0.0
    base = cumulative[k] + (cumulative[k + 1] - cumulative[k]) * min(1.0, max(0.0, fraction))
    target = base - _log(1.0 - attempt.rng.random())
    after = _bisect_right(cumulative, target, k + 1)
    index = max(first, after - 1)
    if after <= stamps and index < stamps:
        attempt.buckets[index].append(signal)

"""One walk of the paper's greedy algorithm (§4.3) on a :class:`Plan`: its state and its moves.

Walk the time stamps t_0 .. t_{n-1}.  At each stamp every available signal is a candidate
with the probability the table gives it there (owed signals first, with a raised weight);
candidates are tried in random order.  For a candidate: draw its start in
[max(t_j, frontier), t_{j+1}), check the partial animation with the start and an open stop;
draw its stop (triangular, mode at the middle of [min, max]) and check again.  When a drawn
time fails, the ad-hoc inference computes the exact set of times the instantiated constraints
allow (critical points, docs/sampler.md) and draws inside it, so equalities and offsets are
met exactly.  Starts never decrease.  The walk over the stamps (with its checkpoints and
backtracking) is in walk.py; the obligations (owed signals, their deadlines and
prerequisites) in debts.py; this module holds the state, the checks and placing.
"""

from __future__ import annotations

import math
import random

from mse.ir.schedule import Occurrence
from mse.solve.greedy.debts import Doomed, latest_start
from mse.solve.greedy.partial import Box, CompiledConstraint
from mse.solve.greedy.plan import InitialDebts, PartnerBounds, Plan, SignalPlan
from mse.solve.greedy.windows import (
    Intervals,
    critical_rules,
    critical_values,
    feasible,
    latest_feasible,
    nearest_feasible,
    pick_uniform,
    probes,
)

# bound once: the walk calls them tens of thousands of times per second
_sqrt = math.sqrt


#: What :meth:`Attempt.commit` restores when a placement is taken back: last stop of the
#: signal, when its modality is free, frontier, owing, latest, needs, stuck.
_Saved = tuple[
    int | None, int | None, int, set[str], dict[str, int], dict[str, tuple[str, ...]], frozenset[str]
]


class Attempt:
    """The mutable state of one walk: placed occurrences, frontier, obligations."""

    __slots__ = (
        "buckets", "checked", "count", "dead", "env", "forbid", "frontier", "last_stop", "latest",
        "memo", "modality_free", "needs", "occurrences", "owing", "placements", "plan", "require", "rng", "stamp_low",
        "stuck", "work",
    )

    def __init__(self, plan: Plan, rng: random.Random, forbid: frozenset[str], require: frozenset[str]) -> None:
        self.plan = plan
        self.rng = rng
        self.forbid = forbid
        self.require = require
        self.env: dict[str, list[Box]] = {}
        self.count: dict[str, int] = {}
        self.last_stop: dict[str, int] = {}
        self.modality_free: dict[str, int] = {}  # exclusive modality -> when it is free again
        self.frontier = 0
        self.stamp_low = 0  # start of the current stamp
        self.occurrences: list[Occurrence] = []  # placed since the last commit (all, unless streaming)
        self.placements = 0  # occurrences placed so far: a version number of the state
        self.work = 0  # partial checks made (a deterministic measure of effort: walk.py caps it)
        self.owing: set[str] = set()  # ids of constraints violated if nothing more occurred
        self.latest: dict[str, int] = {}  # owed signal -> latest start that may pay its debt
        # owed signal that cannot be placed yet -> the prerequisites it waits for (debts.py)
        self.needs: dict[str, tuple[str, ...]] = {}
        self.stuck: frozenset[str] = frozenset()  # owed signals that found no latest start
        self.checked: tuple[str, Box, list[str]] | None = None  # last accepted check
        # (signal, box) -> the verdict of allows() and the constraints it leaves owing, for the
        # current state: emptied by every change of the placed occurrences (place, truncate)
        # and put back when a placement is taken back (_undo restores the state before it).
        self.memo: dict[tuple[str, Box], list[str] | None] = {}
        self.dead: set[str] = set(forbid)  # signals that can no longer be placed in this walk
        # buckets[j]: signals whose next candidacy is at stamp j (see Plan.cumulative)
        self.buckets: list[list[SignalPlan]] = [[] for _ in range(len(plan.stamps) - 1)]

    # -- structure -------------------------------------------------------------------------
    def earliest(self, signal: SignalPlan, frontier: int, extra: tuple[SignalPlan, int] | None = None) -> int:
        """Earliest start the semantics' occurrence rules allow (``extra``: a candidate
        placed at ``extra[1]`` before it, whose shortest stop counts)."""
        low = max(frontier, self.last_stop.get(signal.id, 0))
        if signal.exclusive is not None:
            low = max(low, self.modality_free.get(signal.exclusive, 0))
        if extra is not None:
            other, start = extra
            if other.id == signal.id or (signal.exclusive is not None and other.exclusive == signal.exclusive):
                low = max(low, start + other.shortest)
        return low

    def can_add(self, signal: SignalPlan, pending: int = 0) -> bool:
        return signal.id not in self.forbid and self.count.get(signal.id, 0) + pending < signal.limit

    def future_box(
        self, signal: SignalPlan, frontier: int, extra: tuple[SignalPlan, int] | None, *, bounded: bool = True
    ) -> Box | None:
        """Where one more occurrence of ``signal`` could still go, or None.  ``bounded``: it
        starts after everything in the state (the bounds of start_window assume so)."""
        # can_add and earliest, written out (a hot path: once per partner per failing check)
        sid, exclusive = signal.id, signal.exclusive
        if sid in self.forbid:
            return None
        count = self.count.get(sid, 0)
        if extra is not None and extra[0].id == sid:
            count += 1
        if count >= signal.limit:
            return None
        low = self.last_stop.get(sid, 0)
        if frontier > low:
            low = frontier
        if exclusive is not None:
            free = self.modality_free.get(exclusive, 0)
            if free > low:
                low = free
        if extra is not None:
            candidate, start = extra
            if candidate.id == sid or (exclusive is not None and candidate.exclusive == exclusive):
                start += candidate.shortest
                if start > low:
                    low = start
        first, high = self.plan.fixed[sid]
        if first > low:
            low = first
        # The necessary bounds of its constraints with the partners in the state (as
        # start_window) hold in every world where it occurs.
        if bounded:
            low, high = self.partner_narrowed(self.plan.partner_bounds[signal.id], low, high)
        if low > high:
            return None
        return (low, high, low + signal.shortest, self.plan.duration)

    def settled(self) -> bool:
        """Nothing is owed: the placed occurrences, alone, are a consistent timeline."""
        if self.owing:
            return False
        env = self.env
        return all(env.get(name) for name in self.require)

    # -- checking a candidate --------------------------------------------------------------------
    def allows(self, signal: SignalPlan, box: Box) -> bool:
        """The partial animation plus ``box`` for ``signal`` may still satisfy every
        constraint that names the signal."""
        constraints = self.plan.by_signal[signal.id]
        if not constraints:
            return True
        self.work += 1  # a repeated check counts too: the walk's work bound stays as it was
        key = (signal.id, box)
        if key in self.memo:
            known = self.memo[key]
            if known is None:
                return False
            self.checked = (signal.id, box, known)
            return True
        env = self.env
        boxes = env.get(signal.id)
        if boxes is None:
            boxes = env[signal.id] = []
        boxes.append(box)  # evaluated in place, removed below: no copy of the state
        try:
            optional: dict[str, Box] = {}
            owing: list[str] = []
            by_id, future_box, extra = self.plan.by_id, self.future_box, (signal, box[0])
            for compiled in constraints:
                if compiled.acceptable(env):
                    continue
                owing.append(compiled.id)
                for name in compiled.mentioned:
                    if name not in optional:
                        future = future_box(by_id[name], box[0], extra)
                        if future is not None:
                            optional[name] = future
                if not compiled.in_other_world(env, optional):
                    if compiled is not constraints[0]:  # check the usual culprit first next time
                        constraints.remove(compiled)
                        constraints.insert(0, compiled)
                    self.memo[key] = None
                    return False
            # For a point box these are exactly the constraints that placing it leaves owing.
            self.checked = (signal.id, box, owing)
            self.memo[key] = owing
            return True
        finally:
            boxes.pop()

    def critical(self, signal: SignalPlan, variable: str, start: int | None) -> list[int]:
        """The critical points of :func:`critical_points` (the same set)."""
        plan = self.plan
        rules = plan.critical.get((signal.id, variable))
        if rules is None:
            rules = plan.critical[signal.id, variable] = critical_rules(plan.edges[signal.id], signal, variable)
        return critical_values(rules, self.env, start)

    def start_box(self, signal: SignalPlan, start: int) -> Box:
        return (start, start, start + signal.shortest, min(start + signal.longest, self.plan.duration))

    def starts_box(self, signal: SignalPlan, first: int, last: int) -> Box:
        """Every occurrence starting in [first, last]."""
        return (first, last, first + signal.shortest, min(last + signal.longest, self.plan.duration))

    def feasible_starts(self, signal: SignalPlan, low: int, high: int) -> Intervals:
        # One check of the box holding every start of [low, high] first: the partial check is
        # monotone (a larger box may only add truth values and optional worlds), so when it
        # fails no single start can pass, and the probes below are skipped (usually the case).
        whole = (low, high, low + signal.shortest, min(high + signal.longest, self.plan.duration))
        if not self.allows(signal, whole):
            return []
        return feasible(
            lambda x: self.allows(signal, self.start_box(signal, x)), low, high, self.critical(signal, "start", None)
        )

    def try_place(self, signal: SignalPlan, low: int, high: int) -> bool:
        """Draw, check and place one occurrence starting in [low, high]; False if impossible."""
        sid = signal.id
        if self.count.get(sid, 0) >= signal.limit:
            self.dead.add(sid)
            return False
        env = self.env
        for before in self.plan.needs_before[sid]:
            if not env.get(before):
                return False  # it cannot start before that one is placed (order.py)
        first_start, last_start = self.start_window(signal)
        # Lower bounds only grow (frontier, placed partners) and upper bounds only shrink, so
        # a signal whose window closed stays out for the rest of the walk.
        if first_start > last_start or last_start < low:
            self.dead.add(signal.id)
            return False
        low, high = max(low, first_start), min(high, last_start)
        if self.latest:
            # Starts never decrease: starting past an owed signal's deadline would leave its
            # debt unpayable, so the others wait (the owed one is tried first in its stamp).
            for name, deadline in self.latest.items():
                if name != sid and deadline < high:
                    high = deadline
        if low > high:
            return False
        rng = self.rng
        start = low + int(rng.random() * (high - low + 1))
        # draw_stop(signal, start), inlined (the same draw): once per candidate
        first, last = start + signal.shortest, start + signal.longest
        if last > self.plan.duration:
            last = self.plan.duration
        if last <= first:
            stop = first
        else:
            half, u = (last - first) / 2, rng.random()
            stop = round(last - half * _sqrt(2 * (1 - u))) if u > 0.5 else round(first + half * _sqrt(2 * u))
        window: Intervals | None = [(stop, stop)]
        # The paper checks (start, open stop) and then (start, stop).  A point that passes the
        # second check always passes the first (the open stop's box contains it), so the
        # first check is only run when the pair fails: same outcomes, one check fewer.
        if not self.allows(signal, (start, start, stop, stop)):
            if not self.allows(signal, self.start_box(signal, start)):
                starts = self.feasible_starts(signal, low, high)
                if not starts:
                    return False
                start = pick_uniform(rng, starts)
                stop = self.draw_stop(signal, start)
                window = [(stop, stop)]
            if not self.allows(signal, (start, start, stop, stop)):
                first, last = start + signal.shortest, min(start + signal.longest, self.plan.duration)
                points = self.critical(signal, "stop", start)

                def stop_allowed(y: int) -> bool:
                    return self.allows(signal, (start, start, y, y))

                # The allowed stop nearest to the drawn one; the whole allowed window is only
                # needed (and computed) when that placement is refused below.
                found = nearest_feasible(stop_allowed, first, last, points, stop)
                if found is None:
                    return False
                stop, window = found, None
        if self.commit(signal, start, stop):
            return True
        if window is None:  # the state is as it was before commit(): the same window
            window = feasible(stop_allowed, first, last, points)
        # Placing it would leave a debt that nothing can pay any more (one-step lookahead):
        # try a few other stops of the allowed window, nearest to the drawn one first.
        if window == [(stop, stop)]:
            window = [(start + signal.shortest, min(start + signal.longest, self.plan.duration))]
        others = [y for y in sorted(probes(window), key=lambda y: (abs(y - stop), y)) if y != stop]
        # One trial with the stop open over all of them first: the lookahead is monotone in
        # the candidate's box, so when even that leaves an unpayable debt, every stop does
        # (the usual case: a debt the stop does not settle), and the placements are skipped.
        if len(others) > 1 and not self.open_stop_may_pay(signal, start, min(others), max(others)):
            return False
        return any(self.commit(signal, start, y) for y in others)

    def start_window(self, signal: SignalPlan) -> tuple[int, int]:
        """Earliest and latest start allowed by the occurrence rules and the necessary bounds
        of the constraints (``StartBound``) given the placed occurrences."""
        sid = signal.id
        first_start, last_start = self.plan.fixed[sid]
        # max(first, frontier, last stop, modality free), written out: a hot path
        if self.frontier > first_start:
            first_start = self.frontier
        last_stop = self.last_stop.get(sid)
        if last_stop is not None and last_stop > first_start:
            first_start = last_stop
        if signal.exclusive is not None:
            free = self.modality_free.get(signal.exclusive)
            if free is not None and free > first_start:
                first_start = free
        bounds = self.plan.partner_bounds[sid]
        if not bounds or first_start > last_start:
            # Already empty: the partners could only narrow it more (both callers only ask
            # whether it is empty then), so they are not looked at.
            return first_start, last_start
        return self.partner_narrowed(bounds, first_start, last_start)

    def partner_narrowed(self, bounds: PartnerBounds, low: int, high: int) -> tuple[int, int]:
        """[low, high] narrowed by the necessary start bounds ``bounds`` of a signal's
        constraints with the partners placed in the state.  A partner may be a range (the
        candidate, an open-stop trial's box): a lower bound uses its lowest value, an upper
        bound its highest."""
        env = self.env
        for other, rules in bounds:
            boxes = env.get(other)
            if not boxes:
                continue
            # components never decrease along a signal's boxes: the first has the smallest
            # values (upper bounds), the last the largest (lower bounds)
            first_box, last_box = boxes[0], boxes[-1]
            for index, delta, upper in rules:
                if upper:
                    value = first_box[index + 1] + delta
                    if value < high:
                        high = value
                else:
                    value = last_box[index] + delta
                    if value > low:
                        low = value
        return low, high

    def draw_stop(self, signal: SignalPlan, start: int) -> int:
        """Triangular over [start + min, start + max] with the mode at the middle."""
        first, last = start + signal.shortest, start + signal.longest
        if last > self.plan.duration:
            last = self.plan.duration
        if last <= first:
            return first
        # random.triangular with the mode at the midpoint, inlined (this is a hot path)
        half = (last - first) / 2
        u = self.rng.random()
        if u > 0.5:
            return round(last - half * math.sqrt(2 * (1 - u)))
        return round(first + half * math.sqrt(2 * u))

    # -- placing and taking back -----------------------------------------------------------------
    def commit(self, signal: SignalPlan, start: int, stop: int) -> bool:
        """Place the occurrence unless that leaves an obligation nothing can meet."""
        saved, memo = self._saved(signal), self.memo
        try:
            self.place(signal, start, stop)
        except Doomed:
            self._undo(signal, saved)
            self.memo = memo
            return False
        return True

    def open_stop_may_pay(self, signal: SignalPlan, start: int, low: int, high: int) -> bool:
        """Whether placing ``signal`` at ``start`` with its stop anywhere in [low, high] may
        leave every obligation payable; the state is left as it was.  False means that no
        stop of [low, high] can be committed (the checks are monotone in boxes: a box holding
        every stop may only add truth values and room)."""
        saved, checked, memo = self._saved(signal), self.checked, self.memo
        self.checked = None
        try:
            self.place(signal, start, low, high)
        except Doomed:
            return False
        finally:
            self._undo(signal, saved)
            self.checked = checked  # its checks still count in self.work (the walk's bound)
            self.memo = memo
        return True

    def _saved(self, signal: SignalPlan) -> _Saved:
        return (
            self.last_stop.get(signal.id), self.modality_free.get(signal.exclusive or ""), self.frontier,
            self.owing, self.latest, self.needs, self.stuck,  # replaced, never mutated, once saved
        )

    def _undo(self, signal: SignalPlan, saved: _Saved) -> None:
        """Take back the occurrence :meth:`place` just added (``saved``: :meth:`_saved` before)."""
        last_stop, free, frontier, owing, latest, needs, stuck = saved
        self.frontier, self.owing, self.latest, self.needs, self.stuck = frontier, owing, latest, needs, stuck
        self.env[signal.id].pop()
        self.count[signal.id] -= 1
        if signal.id not in self.forbid:
            self.dead.discard(signal.id)  # it was alive: try_place checked its window
        self.occurrences.pop()
        self.placements -= 1
        if last_stop is None:
            del self.last_stop[signal.id]
        else:
            self.last_stop[signal.id] = last_stop
        if signal.exclusive is not None:
            if free is None:
                del self.modality_free[signal.exclusive]
            else:
                self.modality_free[signal.exclusive] = free

    def place(self, signal: SignalPlan, start: int, stop: int, stop_high: int | None = None) -> None:
        """Place an occurrence (with ``stop_high``: a trial whose stop is anywhere in
        [stop, stop_high]; :meth:`open_stop_may_pay` takes it back)."""
        sid = signal.id
        box = (start, start, stop, stop if stop_high is None else stop_high)
        boxes = self.env.get(sid)
        if boxes is None:
            self.env[sid] = [box]
        else:
            boxes.append(box)
        count = self.count[sid] = self.count.get(sid, 0) + 1
        if count >= signal.limit:
            self.dead.add(sid)
        self.last_stop[sid] = stop
        exclusive = signal.exclusive
        if exclusive is not None:
            free = self.modality_free.get(exclusive, 0)
            self.modality_free[exclusive] = stop if stop > free else free
        self.frontier = start
        self.occurrences.append(Occurrence(start, stop, sid))
        self.placements += 1
        self.memo = {}
        checked, self.checked = self.checked, None
        constraints = self.plan.by_signal[sid]
        if checked is not None and checked[0] == sid and checked[1] == box:
            # allows() just evaluated exactly this state: reuse its verdicts.
            owing = checked[2]
            changed = False
            if owing or self.owing:
                current = self.owing
                for compiled in constraints:
                    cid = compiled.id
                    owes = cid in owing
                    if owes != (cid in current):
                        if not changed:
                            current = self.owing = set(current)  # copy on write (see set_owing)
                            changed = True
                        if owes:
                            current.add(cid)
                        else:
                            current.discard(cid)
        else:
            changed = False
            for compiled in constraints:
                cid = compiled.id
                owes = compiled.violated(self.env)
                if owes != (cid in self.owing):
                    if not changed:
                        self.owing = set(self.owing)  # copy on write: commit() keeps the old one
                        changed = True
                    (self.owing.add if owes else self.owing.discard)(cid)
        if changed or (self.latest and self.narrows_debts(signal)):
            self.refresh_latest(sid)

    def narrows_debts(self, signal: SignalPlan) -> bool:
        """Whether placing ``signal`` may have moved the latest start of an owed signal (or
        of a prerequisite: they have latest starts too)."""
        influence = self.plan.influence[signal.id]
        return any(name in influence for name in self.latest)

    def truncate(self, kept: int, frontier: int, owing: frozenset[str]) -> None:
        """Take back every occurrence after the first ``kept`` of :attr:`occurrences` (a
        checkpoint of walk.py): the state is as it was when they were the whole timeline."""
        taken = self.occurrences[kept:]
        del self.occurrences[kept:]
        self.placements -= len(taken)
        touched: set[str] = set()
        for occurrence in reversed(taken):
            sid = occurrence.signal
            self.env[sid].pop()
            self.count[sid] -= 1
            touched.add(sid)
        modalities: set[str] = set()
        for sid in touched:
            boxes = self.env[sid]
            if boxes:
                self.last_stop[sid] = boxes[-1][2]
            else:
                del self.env[sid]
                del self.count[sid]
                self.last_stop.pop(sid, None)
            exclusive = self.plan.by_id[sid].exclusive
            if exclusive is not None:
                modalities.add(exclusive)
        for modality in modalities:
            stops = [self.last_stop[s.id] for s in self.plan.in_modality[modality] if s.id in self.last_stop]
            if stops:
                self.modality_free[modality] = max(stops)
            else:
                self.modality_free.pop(modality, None)
        self.frontier = frontier
        self.owing = set(owing)
        self.latest, self.needs, self.checked, self.stuck = {}, {}, None, frozenset()
        self.memo = {}
        self.dead = set(self.forbid) | {s.id for s in self.plan.signals if self.count.get(s.id, 0) >= s.limit}

    # -- obligations (docs/sampler.md, "Obligations that only the end settles") ------------------
    def owed_signals(self) -> set[str]:
        owed = {s for s in self.require if not self.env.get(s)}
        owing = self.owing
        if not owing:
            return owed
        by_id, forbid = self.plan.by_constraint_id, self.forbid
        for cid in owing:
            owed.update(name for name in by_id[cid].mentioned if name not in forbid)
        return owed

    def initial_debts(self) -> None:
        """:meth:`refresh_latest` on the empty timeline at stamp 0, computed once per plan and
        request (``Plan.initial_debts``) and copied into this walk: the same result, state
        and work count as computing it (it draws nothing)."""
        key = (self.forbid, self.require)
        found = self.plan.initial_debts.get(key)
        if found is None:
            work = self.work
            try:
                self.refresh_latest()
                doomed = None
            except Doomed as failure:
                doomed = str(failure)
            found = InitialDebts(doomed, dict(self.latest), dict(self.needs), self.stuck, self.checked,
                                 self.work - work)
            self.plan.initial_debts[key] = found
            self.work -= found.work
        self.work += found.work
        self.latest, self.needs = dict(found.latest), dict(found.needs)
        self.stuck, self.checked = found.stuck, found.checked
        if found.doomed is not None:
            raise Doomed(found.doomed)

    def refresh_latest(self, changed: str | None = None, *, expired_only: bool = False) -> None:
        """Latest useful start of every owed signal (the ad-hoc inference over the rest of
        the timeline) and of the prerequisites an owed signal waits for; raise
        :class:`Doomed` when some debt can no longer be paid.

        Incremental: after placing ``changed``, only the signals whose checks it may have
        changed (``Plan.influence``) are searched again, and with ``expired_only`` only
        those whose latest start has passed; the others keep their latest start."""
        plan = self.plan
        previous, previous_needs, previous_stuck = self.latest, self.needs, self.stuck
        full = changed is None and not expired_only
        stuck: set[str] = set()
        influence = plan.influence[changed] if changed is not None else frozenset()
        self.latest, self.needs = {}, {}
        boxes: dict[str, Box] = {}
        caps: dict[str, int] = {}  # prerequisite -> latest start of what waits for it
        searched: set[str] = set()
        pending = sorted(self.owed_signals())
        visits = 0
        while pending and visits < 4 * len(plan.signals):
            name = pending.pop(0)
            visits += 1
            signal = plan.by_id[name]
            if not self.can_add(signal):
                continue
            low, high = self.start_window(signal)
            low = max(low, self.stamp_low)  # no start before the current stamp any more
            high = min(high, caps.get(name, high))
            if low > high:
                continue
            latest = previous.get(name)
            needed = previous_needs.get(name, ())
            if not full and name in previous_stuck and name not in influence and name not in caps:
                stuck.add(name)  # nothing it depends on moved: still no way to place it
                continue
            if full or latest is None or name in influence or not low <= latest <= high:
                searched.add(name)
                needed = ()
                whole = (low, high, low + signal.shortest, min(high + signal.longest, plan.duration))
                before = previous.get(name, high)
                latest = None
                if any(not self.env.get(p) for p in plan.needs_before[name]):
                    pass  # it waits for a prerequisite (order.py)
                elif low <= before <= high and self.allows(signal, self.start_box(signal, before)):
                    latest = before  # what latest_start would answer first: usually unchanged
                elif self.allows(signal, whole):  # monotone: when the box fails, every start does
                    latest = latest_start(
                        lambda x: self.allows(signal, self.start_box(signal, x)),  # noqa: B023
                        lambda: self.critical(signal, "start", None),  # noqa: B023
                        low, high, before,
                        lambda a, b: self.allows(signal, self.starts_box(signal, a, b)),  # noqa: B023
                    )
                if latest is None:
                    # It cannot be placed now; perhaps once other signals are placed before it
                    # (``exists(a) and precedes(a, b)`` with b owed): those become owed too,
                    # due before it.
                    found = self.prerequisites(signal, low, high)
                    if found is not None:
                        latest, needed = found
            if latest is None:
                stuck.add(name)
                continue
            if needed:
                self.needs[name] = needed
                for other in needed:
                    if caps.get(other, high + 1) > latest:
                        caps[other] = latest
                        pending.append(other)
            self.latest[name] = latest
            boxes[name] = (low, latest, low + signal.shortest, plan.duration)
        self.stuck = frozenset(stuck)
        owing = self.owing
        if owing:
            if full:
                suspects = [c for c in plan.constraints if c.id in owing]
            else:
                # Only a debt whose payers moved (or the placed signal's own) may have become
                # unpayable.
                touched = searched | previous.keys() - self.latest.keys()
                if changed is not None:
                    touched.add(changed)
                seen: dict[str, CompiledConstraint] = {}
                for name in sorted(touched):
                    for compiled in plan.by_signal[name]:
                        if compiled.id in owing:
                            seen.setdefault(compiled.id, compiled)
                suspects = list(seen.values())
            for compiled in suspects:
                # Doomed unless the signals that can still start may, together, pay this debt.
                if not compiled.in_other_world(self.env, boxes):
                    raise Doomed(compiled.id)
        for name in self.require:
            if not self.env.get(name) and name not in self.latest:
                raise Doomed(f"require {name}")

    def prerequisites(self, signal: SignalPlan, low: int, high: int) -> tuple[int, tuple[str, ...]] | None:
        """The latest start in [low, high] at which ``signal`` could be placed if some other
        signals were placed before it (from ``low`` on), and those signals; None if none."""
        def needed_at(x: int) -> tuple[str, ...] | None:
            box = self.start_box(signal, x)
            boxes = self.env.setdefault(signal.id, [])
            boxes.append(box)
            try:
                found: set[str] = set()
                for compiled in self.plan.by_signal[signal.id]:
                    if compiled.acceptable(self.env):
                        continue
                    optional: dict[str, Box] = {}
                    strict: dict[str, Box] = {}
                    for name in compiled.mentioned:
                        other = self.plan.by_id[name]
                        early = self.future_box(other, low, None, bounded=False)
                        if early is not None and name != signal.id:
                            optional[name] = early
                        late = self.future_box(other, x, (signal, x))
                        if late is not None:
                            strict[name] = late
                    world = compiled.accepting_world(self.env, optional)
                    if world is None:
                        return None
                    for name in world:
                        # a signal that may as well come after the candidate is no prerequisite
                        trial = {n: optional[n] for n in world if n != name}
                        if name in strict:
                            trial[name] = strict[name]
                        if not compiled.accepts_world(self.env, trial):
                            found.add(name)
                return tuple(sorted(found))
            finally:
                boxes.pop()
                if not boxes:
                    del self.env[signal.id]

        # One relaxed check of the box of every start first (monotone, as in feasible_starts):
        # usually nothing, with or without prerequisites, lets the signal in.
        if not self.relaxed_allows(signal, (low, high, low + signal.shortest,
                                            min(high + signal.longest, self.plan.duration)), low):
            return None
        latest = latest_feasible(
            lambda x: bool(needed_at(x)), low, high, lambda: self.critical(signal, "start", None)
        )
        if latest is None:
            return None
        needed = needed_at(latest)
        return (latest, needed) if needed else None

    def relaxed_allows(self, signal: SignalPlan, box: Box, low: int) -> bool:
        """:meth:`allows` where the other signals may still occur from ``low`` on (before the
        candidate too): what the candidate could have if its prerequisites came first."""
        env = self.env
        boxes = env.setdefault(signal.id, [])
        boxes.append(box)
        try:
            for compiled in self.plan.by_signal[signal.id]:
                if compiled.acceptable(env):
                    continue
                optional: dict[str, Box] = {}
                for name in compiled.mentioned:
                    if name != signal.id:
                        early = self.future_box(self.plan.by_id[name], low, None, bounded=False)
                        if early is not None:
                            optional[name] = early
                if not compiled.in_other_world(env, optional):
                    return False
            return True
        finally:
            boxes.pop()
            if not boxes:
                del env[signal.id]

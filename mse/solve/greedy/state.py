"""The state of one walk of the greedy sampler (engine.py): placed occurrences, frontier,
obligations, and the partial checks of a candidate against it (docs/sampler.md).

:class:`State` holds the data and the read-only questions on it (where a signal may still go,
whether a box passes the partial checks, the critical points); obligations.py adds the
deadlines of the owed signals, engine.py placing and taking back.
"""

from __future__ import annotations

import math
import random

from mse.ir.schedule import Occurrence
from mse.solve.greedy.masks import Box
from mse.solve.greedy.plan import PartnerBounds, Plan, SignalPlan
from mse.solve.greedy.windows import Intervals, critical_rules, critical_values, feasible

#: Larger than any tick: the unbounded window that State.narrowing narrows.
_UNBOUNDED = 1 << 62


class State:
    """The mutable state of one walk: placed occurrences, frontier, obligations."""

    __slots__ = (
        "buckets", "checked", "count", "dead", "env", "forbid", "frontier", "last_stop", "latest",
        "memo", "modality_free", "narrowing", "needs", "occurrences", "owing", "placements", "plan", "require", "rng",
        "stamp_low", "stuck", "work",
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
        # signal -> (lowest, highest) start its placed partners allow (partner_narrowed of
        # an unbounded window): kept across placements, an entry dropped when a partner's
        # occurrences change (:meth:`partners_moved`)
        self.narrowing: dict[str, tuple[int, int]] = {}
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
        constraints = self.plan.gated[signal.id]
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
            get = env.get
            # The signal's own id is the gate of a constraint without one: it is in env here.
            for gate, compiled in constraints:
                if not get(gate) or compiled.acceptable(env):
                    continue
                owing.append(compiled.id)
                for name in compiled.mentioned:
                    if name not in optional:
                        future = future_box(by_id[name], box[0], extra)
                        if future is not None:
                            optional[name] = future
                if not compiled.in_other_world(env, optional):
                    if constraints[0][1] is not compiled:  # check the usual culprit first next time
                        constraints.remove((gate, compiled))
                        constraints.insert(0, (gate, compiled))
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
        if first_start > last_start:
            # Already empty: the partners could only narrow it more (both callers only ask
            # whether it is empty then), so they are not looked at.
            return first_start, last_start
        narrowing = self.narrowing.get(sid)
        if narrowing is None:
            bounds = self.plan.partner_bounds[sid]
            if not bounds:
                return first_start, last_start
            # partner_narrowed only takes maxima and minima: narrowing the unbounded window
            # once and clipping gives the same window
            narrowing = self.narrowing[sid] = self.partner_narrowed(bounds, -_UNBOUNDED, _UNBOUNDED)
        low, high = narrowing
        return (low if low > first_start else first_start), (high if high < last_start else last_start)

    def partners_moved(self, sid: str) -> None:
        """The occurrences of ``sid`` changed: forget the narrowing of the signals it bounds."""
        narrowing = self.narrowing
        if narrowing:
            for name in self.plan.partners_of.get(sid, ()):
                narrowing.pop(name, None)

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

"""The obligations of a walk (docs/sampler.md, "Obligations that only the end settles"): the
owed signals, their latest useful starts (deadlines) and the prerequisites an owed signal waits
for, searched with the partial checks of state.py, and the signals that must still occur planned
together (their windows propagated, their room in an exclusive modality: "Signals that must
occur, planned together"); engine.py calls them after each placement."""

from __future__ import annotations

from mse.solve.greedy.debts import Doomed, latest_start
from mse.solve.greedy.masks import Box
from mse.solve.greedy.partial import CompiledConstraint
from mse.solve.greedy.plan import InitialDebts, SignalPlan
from mse.solve.greedy.state import State
from mse.solve.greedy.windows import latest_feasible

#: Up to this many signals that must still occur in one exclusive modality, check_room also
#: searches for an order in which they fit one after the other (non-preemptive: exact up to
#: ROOM_SEARCH_NODES nodes, then it assumes one exists).
ROOM_SEARCH_JOBS = 8
ROOM_SEARCH_NODES = 400
#: Rounds of propagation of the start bounds between signals that must occur (a chain of k
#: links needs k rounds at most to carry a bound from one end to the other).
PROPAGATION_ROUNDS = 8


def _sequence_exists(jobs: list[tuple[int, int, int, str]]) -> bool:
    """Whether the jobs (release, deadline, length, _) fit one after the other on one
    machine, each inside [release, deadline]: depth-first over the orders, earliest deadline
    first, a branch cut as soon as some job left can no longer meet its deadline.  True also
    when the search runs out of nodes (sound for a doom)."""
    ordered = sorted(jobs, key=lambda job: (job[1], job[0]))
    nodes = [0]

    def visit(time: int, left: tuple[int, ...]) -> bool:
        if not left:
            return True
        nodes[0] += 1
        if nodes[0] > ROOM_SEARCH_NODES:
            return True
        for index in left:
            release, deadline, length, _ = ordered[index]
            if max(time, release) + length > deadline:
                return False  # it cannot wait for any other: no order from here
        for index in left:
            release, deadline, length, _ = ordered[index]
            end = max(time, release) + length
            if visit(end, tuple(i for i in left if i != index)):
                return True
        return False

    return visit(0, tuple(range(len(ordered))))


class Obligations(State):
    """:class:`State` with the deadlines of its owed signals."""

    __slots__ = ()

    def narrows_debts(self, signal: SignalPlan) -> bool:
        """Whether placing ``signal`` may have moved the latest start of an owed signal (or
        of a prerequisite: they have latest starts too)."""
        influence = self.plan.influence[signal.id]
        return any(name in influence for name in self.latest)

    def bounds_must_occur(self, signal: SignalPlan) -> bool:
        """Whether ``signal`` bounds the start of a signal that must still occur but owes
        nothing yet (an implies chain's later link: placing ``signal`` may have closed the
        chain's room, which only :meth:`check_room` sees)."""
        partners = self.plan.partners_of.get(signal.id)
        if not partners or not (self.owing or self.require):
            return False
        must = self.must_occur()
        return any(name in must for name in partners)

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
        self.check_room()
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

    def must_occur(self) -> dict[str, str]:
        """The signals that must still occur, each with the debt that demands it: a required
        signal, an ``exists`` conjunct of an owing constraint (owing means instantiated, so
        the conjunct must hold), what those must be placed after (order.py) and what their
        occurrence implies (``exists(x) implies exists(y)``: an implies chain)."""
        env, plan = self.env, self.plan
        found: dict[str, str] = {name: f"require {name}" for name in sorted(self.require) if not env.get(name)}
        must_exist, needs_before, implied = plan.must_exist, plan.needs_before, plan.implied
        for cid in sorted(cid for cid in self.owing if must_exist[cid]):
            for name in must_exist[cid]:
                if name not in found and not env.get(name):
                    found[name] = cid
        pending = list(found)
        while pending:
            name = pending.pop()
            for group in (needs_before[name], implied.get(name, ())):
                for before in group:
                    if before not in found and not env.get(before):
                        found[before] = found[name]
                        pending.append(before)
        return found

    def check_room(self) -> None:
        """Plan the signals that must still occur (:meth:`must_occur`) together; raise
        :class:`Doomed` when they cannot all be placed.

        1. *Windows*: each gets its start window (occurrence rules, placed partners, latest
           start), then the necessary start bounds between two of them are propagated until
           nothing moves: ``start(b) = stop(a) ± 0.3`` with both bound to occur bounds b by
           a's window and a by b's (a precedes ladder, a chain of equalities with tolerance,
           an implies chain: placing its first link pins the others).  Their latest starts
           become the narrowed ones, so the walk keeps their room.
        2. *Room*: in one exclusive modality they need their shortest lengths one at a time
           inside their windows: the preemptive relaxation (for every window, the lengths
           that must lie inside it add up to no more than its length), then, for a few, a
           search for an order that fits (late mandatory signals whose room optional ones
           took).

        Every step is a necessary condition: it never dooms a state that has a completion."""
        owing = self.owing
        if not owing and not self.require:
            return
        must = self.must_occur()
        if len(must) < 2:
            return
        plan = self.plan
        by_id, env = plan.by_id, self.env
        windows: dict[str, list[int]] = {}
        for name in must:
            signal = by_id[name]
            if not self.can_add(signal):
                continue
            low, high = self.start_window(signal)
            low = max(low, self.stamp_low)
            high = min(high, self.latest.get(name, high))
            if low > high:
                raise Doomed(must[name])
            windows[name] = [low, high]
        # (my name, my window, partner's window, ((bound is upper, offset), ...)): a rule on
        # the partner's stop (index 2) adds its longest length to an upper bound, its shortest
        # to a lower one
        links = []
        order_free_offsets = plan.order_free_offsets
        for name, window in windows.items():
            for other, rules in order_free_offsets[name]:
                theirs = windows.get(other)
                if theirs is not None and not env.get(other):  # placed ones: in start_window
                    links.append((name, window, theirs, rules))
        for _ in range(PROPAGATION_ROUNDS if links else 0):
            moved = False
            for name, window, theirs, rules in links:
                for upper, offset in rules:
                    if upper:
                        value = theirs[1] + offset
                        if value < window[1]:
                            window[1], moved = value, True
                    else:
                        value = theirs[0] + offset
                        if value > window[0]:
                            window[0], moved = value, True
                if window[0] > window[1]:
                    raise Doomed(must[name])
            if not moved:
                break
        latest = self.latest
        groups: dict[str, list[tuple[int, int, int, str]]] = {}
        for name, (low, high) in windows.items():
            if name in latest and high < latest[name]:
                latest[name] = high
            signal = by_id[name]
            if signal.exclusive is not None:
                job = (low, high + signal.shortest, signal.shortest, must[name])
                groups.setdefault(signal.exclusive, []).append(job)
        for jobs in groups.values():
            if len(jobs) < 2:
                continue
            jobs.sort()
            for index, job in enumerate(jobs):
                first = job[0]
                if index and jobs[index - 1][0] == first:
                    continue  # the same window start: checked with the first of them
                # every job released from ``first`` on, by deadline: the lengths due by each
                # deadline must fit between ``first`` and it
                total = 0
                for deadline, length, reason in sorted((j[1], j[2], j[3]) for j in jobs[index:]):
                    total += length
                    if total > deadline - first:
                        raise Doomed(reason)
            if len(jobs) <= ROOM_SEARCH_JOBS and not _sequence_exists(jobs):
                raise Doomed(min(jobs, key=lambda job: job[1])[3])

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
        # The cells of starts are searched by halves, a half skipped when the relaxed check of
        # its box fails (monotone, and sound for the worlds: then no start of it has an
        # accepting world, so needed_at gives None there): the same answer, fewer searches.
        answers: dict[int, tuple[str, ...] | None] = {}

        def needs_some(x: int) -> bool:
            found = answers[x] = needed_at(x)
            return bool(found)

        latest = latest_feasible(
            needs_some, low, high, lambda: self.critical(signal, "start", None),
            lambda a, b: self.relaxed_allows(signal, self.starts_box(signal, a, b), low),
        )
        if latest is None:
            return None
        needed = answers[latest] if latest in answers else needed_at(latest)
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

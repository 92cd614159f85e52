"""One walk of the paper's greedy algorithm (§4.3) on a :class:`Plan`: its state and its moves.

Walk the time stamps t_0 .. t_{n-1}.  At each stamp every available signal is a candidate
with the probability the table gives it there (owed signals first, with a raised weight); the
others are tried in the order of the starts drawn for them.  For a candidate: draw its start
in [max(t_j, frontier), t_{j+1}), check the partial animation with the start and an open stop;
draw its stop (triangular, mode at the middle of [min, max]) and check again.  A candidate
nothing owes is rejected when a drawn time fails, and its placement is weighed by the prior
(the debts it takes on, the starts it closes to others: docs/sampler.md).  For an owed one,
when a drawn time fails, the ad-hoc inference computes the exact set of times the
instantiated constraints allow (critical points) and draws inside it, so equalities and
offsets are met exactly.  Starts never decrease.  The walk over the stamps (with its checkpoints and
backtracking) is in walk.py; the state and its partial checks in state.py; the obligations
(owed signals, their deadlines and prerequisites) in obligations.py; this module holds
trying, placing and taking back.
"""

from __future__ import annotations

import math
from typing import Any

from mse.ir.schedule import Occurrence
from mse.solve.greedy.debts import Doomed
from mse.solve.greedy.obligations import Obligations
from mse.solve.greedy.plan import Plan, SignalPlan, prior_starts_in
from mse.solve.greedy.windows import Intervals, feasible, nearest_feasible, pick_uniform, probes

__all__ = ["Attempt", "Doomed"]

# bound once: the walk calls them tens of thousands of times per second
_sqrt = math.sqrt


#: What :meth:`Attempt.commit` restores when a placement is taken back: last stop of the
#: signal, when its modality is free, frontier, owing, latest, needs, stuck.
_Saved = tuple[
    int | None, int | None, int, set[str], dict[str, int], dict[str, tuple[str, ...]], frozenset[str]
]


def _narrowable(plan: Plan, signal: SignalPlan) -> tuple[tuple[str, SignalPlan, tuple[str, ...]], ...]:
    """The signals whose start window a placement of ``signal`` may narrow, whatever the
    state (:meth:`Attempt.narrowed_by` keeps the free ones): the other members of its
    exclusive modality, then the signals its necessary start bounds name, each with the
    signals it waits for or cannot occur without (``Plan.needs_before``, ``Plan.requires``)."""
    found: dict[str, SignalPlan] = {}
    if signal.exclusive is not None:
        for other in plan.in_modality[signal.exclusive]:
            found[other.id] = other
    for name in plan.partners_of.get(signal.id, ()):
        found[name] = plan.by_id[name]
    found.pop(signal.id, None)
    return tuple((name, other, (*plan.needs_before[name], *plan.requires[name])) for name, other in found.items())


class Attempt(Obligations):
    """One walk's state and its moves: trying, placing and taking back occurrences."""

    __slots__ = ("careful", "offsets", "sharing")

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        #: Set by walk.py after the walk's first failure, or from its start when the empty
        #: timeline owes many debts: a candidate that is not owed may not add a debt (it
        #: keeps the room the owed signals need; docs/sampler.md, "Sixth pass").
        self.careful = False
        #: The owed signals of the current stamp that share their debts with other payers and
        #: are not due yet (walk.walk_stamp): their placement is weighed like an optional one's
        #: by the starts it closes (prior_spares); one of the others may still pay.
        self.sharing: frozenset[str] = frozenset()
        #: Per candidate of the current stamp, where in the stamp (0..1) the prior starts it
        #: (walk.walk_stamp draws them and tries the candidates in that order).
        self.offsets: dict[str, float] = {}

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
        optional = sid not in self.latest and sid not in self.require
        if optional:
            # An optional candidate starts where the prior puts it in the stamp; outside its
            # window it is rejected, as the target rejects that draw (it keeps its hazard for
            # later stamps).  Drawn inside the window, a signal whose window a partner narrows
            # to a band (``equal(start(b), stop(a), 0.3)``) took the whole stamp's chance.
            # (a repetitive one: from its last stop, where its hazard is counted from)
            since = max(low, self.last_stop.get(sid, 0))
            if since > high:
                return False
            offset = self.offsets.get(sid)
            # (over the starts of the stamp where its shortest length fits: its hazard's)
            stamp_high = min(high, self.plan.duration - signal.shortest)
            drawn = -1 if offset is None else self.stamp_low + int(offset * (stamp_high - self.stamp_low + 1))
            if drawn < since:  # it starts after the frontier or its own last stop: uniformly there
                drawn = since + int(self.rng.random() * (high - since + 1))
            if not first_start <= drawn <= last_start:
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
        # What a placement of an optional candidate (one nothing owes) is weighed against:
        # the owed signals before it (prior_pays).
        owed, saved = (None, None) if sid in self.latest or sid in self.require else (self.latest, self._saved(signal))
        if optional:
            if not low <= drawn <= high:
                return False  # past an owed signal's deadline
            start = drawn
        else:
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
            if owed is not None:
                # An optional candidate whose drawn start and stop fail is rejected, as the
                # target rejects that draw (it keeps its hazard for later stamps); moving it to
                # the allowed times is for owed signals, which must pay.
                return False
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
        # ... and the windows of the free signals its placement may narrow (prior_spares)
        spared = self.windows_of(self.narrowed_by(signal)) if owed is not None or sid in self.sharing else None
        sharing_saved = self._saved(signal) if owed is None and spared else None
        if self.commit(signal, start, stop, saved or sharing_saved):
            if sharing_saved is not None and not self.prior_spares(signal, start, stop, spared or []):
                self.take_back(signal, sharing_saved)
                return False
            if owed is None or saved is None or (
                (self.latest == owed or self.prior_pays(signal, owed))
                and (not spared or self.prior_spares(signal, start, stop, spared))
            ):
                return True
            self.take_back(signal, saved)
            return False
        if owed is not None:
            # An optional candidate whose drawn stop leaves a debt nothing can pay: the target
            # rejects that draw (trying other stops, unweighed, placed `b` of ``exists(a) and
            # includes(a, b)`` with `a` forced to start at the same millisecond).
            return False
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
        if (len(others) <= 1 or self.open_stop_may_pay(signal, start, min(others), max(others))) and any(
            self.commit(signal, start, y) for y in others
        ):
            return True
        if sid in self.latest and sid in self.must_occur():
            # A signal that must occur whose drawn start leaves the others no room (a late
            # mandatory signal's room, a chain's next link): its earliest allowed start is
            # the one that leaves them the most (docs/sampler.md, "Signals that must occur").
            starts = self.feasible_starts(signal, low, high)
            if starts and starts[0][0] < start:
                return self.place_at(signal, starts[0][0])
        return False

    def place_at(self, signal: SignalPlan, start: int) -> bool:
        """Place ``signal`` at ``start`` with a drawn stop or, when that fails, the earliest
        allowed stop (the one that leaves the others the most room); False when neither
        can be committed."""
        stop = self.draw_stop(signal, start)
        if self.allows(signal, (start, start, stop, stop)) and self.commit(signal, start, stop):
            return True
        first, last = start + signal.shortest, min(start + signal.longest, self.plan.duration)
        window = feasible(lambda y: self.allows(signal, (start, start, y, y)), first, last,
                          self.critical(signal, "stop", start))
        return bool(window) and window[0][0] != stop and self.commit(signal, start, window[0][0])

    def prior_pays(self, signal: SignalPlan, before: dict[str, int]) -> bool:
        """Whether to keep the placement of an optional candidate that made new signals owed
        (``before``: the owed signals and deadlines before it): with the probability that the
        prior alone starts one of them where it pays (its allowed starts up to its deadline).

        Without this weight, every such placement was kept and its debt paid by the owed
        signals' forced candidacies and exact inference (obligations.py): a signal whose
        constraint needs a partner at a precise time (``includes(frown, lean_forward)`` with
        no frown running: a frown starting at the same millisecond) occurred at its own prior
        rate, where the target (the prior conditioned on consistency) makes it rare, and its
        partner came with it: the walk was busier than the target (docs/sampler.md, "Debts
        weighed by the prior")."""
        plan, duration = self.plan, self.plan.duration
        low = max(self.frontier, self.stamp_low)
        payers = [(plan.by_id[name], deadline) for name, deadline in self.latest.items()
                  if name not in before and name != signal.id]
        # Signals owed already whose deadline it brought forward (``includes(frown, lean)``
        # placing lean while a disjunction owes a frown: now one must start at that very
        # millisecond): kept with the ratio of the prior's chances to start one in time.
        hastened = [(plan.by_id[name], deadline, before[name]) for name, deadline in self.latest.items()
                    if name in before and deadline < before[name] and name != signal.id]
        if not payers and not hastened:
            return True  # only the placed signal itself owes another occurrence of it
        draw = self.rng.random()  # kept iff draw >= the probability that none pays
        keep = 1.0
        for payer, deadline, previous in hastened:
            was = prior_starts_in(payer, [(low, previous)] if low <= previous else [], low, duration)
            if was > 0:
                starts = self.feasible_starts(payer, low, deadline) if low <= deadline else []
                keep *= min(1.0, prior_starts_in(payer, starts, low, duration) / was)
        if not payers:
            return draw < keep
        # First with every start up to each deadline allowed (no probing): an upper bound of
        # each payment, so a lower bound of "none pays"; usually enough to reject at once.
        bound = 1.0
        for payer, deadline in payers:
            bound *= 1.0 - prior_starts_in(payer, [(low, deadline)] if low <= deadline else [], low, duration)
        if draw >= keep * (1.0 - bound):
            return False
        missed = 1.0
        for payer, deadline in payers:
            starts = self.feasible_starts(payer, low, deadline) if low <= deadline else []
            missed *= 1.0 - prior_starts_in(payer, starts, low, duration)
        return draw < keep * (1.0 - missed)

    def narrowed_by(self, signal: SignalPlan) -> list[SignalPlan]:
        """The free signals whose start window a placement of ``signal`` may narrow: the
        other members of its exclusive modality and the signals its necessary start bounds
        name (``Plan.partners_of``), neither owed (their debts are weighed apart), required
        nor out of the walk."""
        plan, dead, latest, require, env = self.plan, self.dead, self.latest, self.require, self.env
        candidates = plan.narrowable.get(signal.id)
        if candidates is None:
            candidates = plan.narrowable[signal.id] = _narrowable(plan, signal)
        # One that waits for a prerequisite or cannot occur without a signal not placed yet
        # (this one, perhaps) has no starts to lose: the prior's draws of it are
        # inconsistent anyway.
        found = []
        for name, other, needed in candidates:
            if name in dead or name in latest or name in require:
                continue
            for before in needed:
                if not env.get(before):
                    break
            else:
                found.append(other)
        return found

    def windows_of(self, signals: list[SignalPlan]) -> list[tuple[SignalPlan, int, int]]:
        """Their start windows (:meth:`start_window`), the empty ones left out."""
        found = []
        for other in signals:
            first, last = self.start_window(other)
            if first <= last:
                found.append((other, first, last))
        return found

    def prior_spares(
        self, signal: SignalPlan, start: int, stop: int, before: list[tuple[SignalPlan, int, int]]
    ) -> bool:
        """Whether to keep the placement of an optional candidate that closes starts of other
        free signals (``before``: their start windows without it): with the probability that
        the prior alone starts none of them where it no longer may.

        The target (the prior conditioned on consistency) rejects the draws where a signal
        starts inside another of its exclusive modality, or where ``start(b) > stop(a)``
        has ``a`` after ``b``; the walk, deciding in time order, placed the first at its prior
        rate and only moved the others later: members of an exclusive modality, and the
        partners of such bounds, occurred more often than the target has them
        (docs/sampler.md, "Starts a placement closes")."""
        plan = self.plan
        duration, low = plan.duration, self.stamp_low
        # The window after the placement is the one before narrowed by what the placement
        # adds (start_window's rules, written for this one occurrence): the end of its run in
        # an exclusive modality, and the necessary bounds that name it (an upper bound uses a
        # signal's first occurrence: only its first one counts).
        box = (start, start, stop, stop)
        first_one = self.count.get(signal.id, 0) <= 1
        missed = 1.0
        for other, first, last in before:
            first = max(first, start)
            if first > last:
                continue
            after_first, after_last = first, last
            if signal.exclusive is not None and other.exclusive == signal.exclusive and stop > after_first:
                after_first = stop
            for partner, rules in plan.partner_bounds[other.id]:
                if partner == signal.id:
                    for index, delta, upper in rules:
                        if upper:
                            if first_one and box[index + 1] + delta < after_last:
                                after_last = box[index + 1] + delta
                        elif box[index] + delta > after_first:
                            after_first = box[index] + delta
            if after_first > after_last:
                closed = [(first, last)]
            else:
                closed = [(first, min(last, after_first - 1)), (max(first, after_last + 1), last)]
                closed = [(a, b) for a, b in closed if a <= b]
            if closed:
                missed *= 1.0 - prior_starts_in(other, closed, low, duration)
        if missed >= 1.0:
            return True
        # Against the timelines where it does not start here: it may start later, closing as
        # much (``later``: the prior's probability that it does), so the weight of this
        # start is the ratio, not ``missed`` alone (a signal that surely occurs loses little).
        # A once-only signal that does not start here may start later, anywhere.  A repetitive one that does not start
        # here starts again soon, and an occurrence then closes about the same span only
        # when it comes within that span: ``later`` is the probability of a start within its
        # mean length (counting its whole future would cancel the weight; counting none
        # halved the rates of two repetitive signals sharing an exclusive modality).
        plan = self.plan
        cumulative = plan.cumulative[signal.index]
        first = plan.stamp_of(start)
        if signal.limit > 1:
            until = plan.stamp_of(min(plan.duration - 1, start + (signal.shortest + signal.longest) // 2))
            later = 1.0 - math.exp(cumulative[first] - cumulative[until + 1])
        else:
            later = 1.0 - math.exp(cumulative[first] - cumulative[-1])
        # missed / (1 - later + later * missed), without dividing (missed 0 and later 1: 0)
        return self.rng.random() * (1.0 - later + later * missed) < missed

    def take_back(self, signal: SignalPlan, saved: _Saved) -> None:
        """Undo the placement :meth:`commit` just made (``saved``: :meth:`_saved` before it)."""
        self._undo(signal, saved)
        self.memo, self.checked = {}, None

    # -- placing and taking back -----------------------------------------------------------------
    def commit(self, signal: SignalPlan, start: int, stop: int, saved: _Saved | None = None) -> bool:
        """Place the occurrence unless that leaves an obligation nothing can meet (``saved``:
        :meth:`_saved` of the current state, when the caller has it)."""
        memo = self.memo
        if saved is None:
            saved = self._saved(signal)
        try:
            self.place(signal, start, stop)
        except Doomed:
            self._undo(signal, saved)
            self.memo = memo
            return False
        if self.careful and not self.owing <= saved[3] and signal.id not in saved[4]:
            # careful: a placement that owes nothing but adds a debt is taken back (it could
            # leave the owed signals no room together, which the lookahead does not see)
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
        self.partners_moved(signal.id)
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
        self.partners_moved(sid)
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
                # The signal's constraints owing now are exactly ``owing``: replace their part
                # of the owing set when it differs (a new set: commit() keeps the old one).
                mine, current = self.plan.constraint_ids[sid], self.owing
                now = set(owing)
                if current & mine != now:
                    self.owing = (current - mine) | now
                    changed = True
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
        if changed or (self.latest and self.narrows_debts(signal)) or self.bounds_must_occur(signal):
            self.refresh_latest(sid)

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
        self.memo, self.narrowing = {}, {}
        self.dead = set(self.forbid) | {s.id for s in self.plan.signals if self.count.get(s.id, 0) >= s.limit}

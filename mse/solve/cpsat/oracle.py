"""Answers to deep lint's questions "is there a consistent timeline where X?", cheapest first.

A :class:`Question` names the few signals it is about (``free``), says how to recognise an
answer in a timeline (``goal``) and how to ask it of an encoding (``literals``); it may
leave one constraint out (``drop``: "violated while the others hold").  The
:class:`Oracle` keeps a *base* timeline (consistent, made sparse so that signals have room
to move) and asks, in this order:

1. **quick**: a few placements of the free signals in the base (absent, or one occurrence
   at a handful of times), checked by the evaluator on the constraints that name them;
2. **local**: CP-SAT with only the free signals moving (then their neighbours too) and
   every other signal at its base occurrences (constants);
3. **disproof**: CP-SAT on the constraints that name the free signals (then their
   neighbours too) alone, every signal they name free: leaving rules out only adds
   timelines, so "infeasible" there is a proof for the whole set (steps 2 and 3 alternate,
   nearest first);
4. **full**: one switchable model of the whole set, by assumptions.

Steps 1-3 cost the same whatever the size of the set, which keeps lint about linear.  A
timeline found by steps 1-2 differs from the base only in free signals, and only the
constraints naming them can change: each is re-checked, so it is a real witness.
"""

from __future__ import annotations

import random
import time
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from mse.ir import model as ir
from mse.ir.evaluate import constraint_status, intervals_of, is_instantiated
from mse.ir.relations import known_time
from mse.ir.schedule import Occurrence, Schedule
from mse.solve.bounds import length_bounds, slot_counts
from mse.solve.cpsat.encode import Encoding, Frame, Lit, build

Intervals = dict[str, list[tuple[int, int]]]
#: Placements tried per free signal by the quick step, and combinations in all.
QUICK_STARTS = 6
QUICK_COMBOS = 160
#: Consistent timelines besides the base that the quick step tries.
POOL = 3
#: A query's wall-clock safety limit, as a multiple of its deterministic budget.
WALL_FACTOR = 20


@dataclass(frozen=True)
class Question:
    free: frozenset[str]
    goal: Callable[[Mapping[str, Sequence[tuple[int, int]]]], bool]
    literals: Callable[[Encoding], Sequence[Lit] | None]
    drop: str | None = None

    @property
    def harvest(self) -> bool:
        """Witnesses of questions that drop a constraint are not consistent timelines."""
        return self.drop is None


@dataclass
class Seen:
    """What consistent timelines have shown."""

    present: set[str] = field(default_factory=set)
    absent: set[str] = field(default_factory=set)
    instantiated: set[str] = field(default_factory=set)
    early: set[str] = field(default_factory=set)


class Oracle:
    def __init__(self, model: ir.Model, ticks: int, query_time: float, stamp: int) -> None:
        self.model = model
        self.ticks = ticks
        self.query_time = query_time
        self.stamp = stamp
        self.seen = Seen()
        self.base: Intervals = {}
        #: Other consistent timelines the quick step tries too (the latest found).
        self.pool: list[Intervals] = []
        self.redundant: list[str] = []  # constraint ids left out of every later question
        self.stats: Counter[str] = Counter()
        self.whole_seconds = 0.0  # spent on questions of the whole set
        self._full: Encoding | None = None
        self._rng = random.Random(0)
        self.touching: dict[str, list[ir.Constraint]] = {}
        for constraint in model.constraints:
            for name in ir.mentioned_signals(constraint.expr):
                self.touching.setdefault(name, []).append(constraint)

    # -- what timelines show ----------------------------------------------------------------
    def harvest(self, intervals: Mapping[str, Sequence[tuple[int, int]]],
                changed: set[str] | None = None) -> None:
        """Record what a consistent timeline shows (only about ``changed`` signals and the
        constraints naming them, when the rest is known from the base)."""
        names = [s.id for s in self.model.signals] if changed is None else sorted(changed)
        for name in names:
            occurrences = intervals.get(name)
            if occurrences:
                self.seen.present.add(name)
                if min(o[0] for o in occurrences) < self.stamp:
                    self.seen.early.add(name)
            else:
                self.seen.absent.add(name)
        constraints = (self.model.constraints if changed is None
                       else {c.id: c for n in changed for c in self.touching.get(n, ())}.values())
        for constraint in constraints:
            if is_instantiated(constraint, intervals):
                self.seen.instantiated.add(constraint.id)

    def set_base(self, intervals: Intervals) -> None:
        """Make ``intervals`` (consistent) the base, with every occurrence that no constraint
        needs removed (greedily): sparse timelines leave room for the quick and local steps."""
        base = {name: list(spans) for name, spans in intervals.items() if spans}
        for name in sorted(base, key=lambda n: (len(self.touching.get(n, ())), n)):
            spans = base.pop(name)
            if any(constraint_status(c, base, self.ticks) is False for c in self.touching.get(name, ())):
                base[name] = spans
        self.base = base
        self.harvest(base)

    # -- the steps -------------------------------------------------------------------------
    def quick(self, question: Question) -> bool:
        if self._quick(question):
            self.stats["quick"] += 1
            return True
        return False

    def ask(self, question: Question, *, whole: bool = True) -> str:
        """'feasible' | 'infeasible' | 'unknown' ('skipped' when only the whole set could
        answer and ``whole`` is False)."""
        if self._quick(question):
            self.stats["quick"] += 1
            return "feasible"
        around = set(question.free)
        for radius in range(2):
            if self._local(question, around):
                self.stats[f"local {radius}"] += 1
                return "feasible"
            if self._disproved(question, around):
                self.stats[f"disproof {radius}"] += 1
                return "infeasible"
            around = self._neighbours(around)
        if not whole:
            self.stats["skipped"] += 1
            return "skipped"
        self.stats["full"] += 1
        began = time.process_time()  # CPU time: the budget does not shrink when the machine is busy
        try:
            return self._ask_full(question)
        finally:
            self.whole_seconds += time.process_time() - began

    def _checks(self, question: Question) -> list[ir.Constraint]:
        ignored = {question.drop, *self.redundant}
        found = {c.id: c for n in question.free for c in self.touching.get(n, ()) if c.id not in ignored}
        return list(found.values())

    def _anchors(self, name: str, others: Mapping[str, Sequence[tuple[int, int]]]) -> tuple[set[int], set[int]]:
        """Starts and stops of ``name`` that its constraints single out given ``others``: the
        edges of the occurrences it is related to, shifted by the constants of the relation."""
        starts: set[int] = set()
        stops: set[int] = set()
        for constraint in self.touching.get(name, ()):
            for node in ir.walk(constraint.expr):
                if isinstance(node, ir.Relation):
                    other = node.right if node.left == name else node.left if node.right == name else None
                    for a, b in others.get(other, ()) if other else ():
                        starts |= {a, b}
                        stops |= {a, b}
                elif isinstance(node, ir.Compare):
                    for mine, theirs in ((node.left, node.right), (node.right, node.left)):
                        if not (isinstance(mine, ir.SignalTime) and mine.signal == name):
                            continue
                        values = ([(a if theirs.edge == "start" else b) + theirs.offset
                                   for a, b in others.get(theirs.signal, ())]
                                  if isinstance(theirs, ir.SignalTime) else [known_time(theirs, self.ticks)])
                        for value in values:
                            edge = value - mine.offset
                            for t in (edge - 1, edge, edge + 1):
                                (starts if mine.edge == "start" else stops).add(t)
        return starts, stops

    def _placements(self, name: str, others: Mapping[str, Sequence[tuple[int, int]]]) -> list[tuple[int, int] | None]:
        """Absent, or one occurrence: at the anchors of its constraints first, then spread."""
        signal = self.model.signal(name)
        low, high = length_bounds(signal, self.ticks)
        if low > self.ticks:
            return [None]
        last = self.ticks - low
        anchored, stops = self._anchors(name, others)
        spread = {0, last, self.stamp // 2} | {last * k // (QUICK_STARTS - 1) for k in range(QUICK_STARTS)}
        spread |= {self._rng.randint(0, last) for _ in range(2)}
        lengths = sorted({low, max(low, min(high, (low + high) // 2)), min(high, self.ticks)})
        found: dict[tuple[int, int], None] = {}
        for stop in sorted(stops):
            for length in lengths:
                if stop - length >= 0 and stop <= self.ticks:
                    found[(stop - length, stop)] = None
        for start in sorted(anchored) + sorted(spread - anchored):
            for length in lengths:
                if start >= 0 and start + length <= self.ticks:
                    found[(start, start + length)] = None
        return [None, *found]

    def _quick(self, question: Question) -> bool:
        """A witness among a few placements of the free signals in the base or in another
        known consistent timeline (at most one occurrence each), or False."""
        if len(question.free) > 3:
            return False
        return any(self._quick_in(question, base) for base in [self.base, *self.pool])

    def _remember(self, intervals: Intervals) -> None:
        self.pool = [intervals, *self.pool[:POOL - 1]]

    def _quick_in(self, question: Question, base: Intervals) -> bool:
        free = sorted(question.free)
        exclusive = self.model.exclusive_modalities
        others = {n: spans for n, spans in base.items() if n not in question.free}
        busy: dict[str, list[tuple[int, int]]] = {}
        for name, spans in others.items():
            modality = self.model.signal(name).modality
            if modality in exclusive:
                busy.setdefault(modality, []).extend(spans)
        checks = self._checks(question)
        choices = [self._placements(name, others) for name in free]
        combos: list[tuple[tuple[int, int] | None, ...]] = [()]
        for options in choices:
            combos = [(*combo, option) for combo in combos for option in options]
            if len(combos) > QUICK_COMBOS:
                combos = combos[:QUICK_COMBOS // 2] + self._rng.sample(combos[QUICK_COMBOS // 2:], QUICK_COMBOS // 2)
        for combo in combos:
            taken: dict[str, list[tuple[int, int]]] = {}
            clash = False
            for name, span in zip(free, combo, strict=True):
                modality = self.model.signal(name).modality
                if span is None or modality not in exclusive:
                    continue
                if any(a < span[1] and span[0] < b for a, b in busy.get(modality, []) + taken.get(modality, [])):
                    clash = True
                    break
                taken.setdefault(modality, []).append(span)
            if clash:
                continue
            intervals = dict(others)
            for name, span in zip(free, combo, strict=True):
                if span is not None:
                    intervals[name] = [span]
            if not question.goal(intervals):
                continue
            if any(constraint_status(c, intervals, self.ticks) is False for c in checks):
                continue
            if question.harvest:
                self.harvest(intervals, set(free))
            return True
        return False

    def _neighbours(self, names: set[str]) -> set[str]:
        """``names``, the signals their constraints name, and the base occurrences that share
        an exclusive modality with them (they may have to make room)."""
        model = self.model
        around = names | {n for s in names for c in self.touching.get(s, ()) for n in ir.mentioned_signals(c.expr)}
        modalities = {model.signal(n).modality for n in names} & model.exclusive_modalities
        return around | {n for n in self.base if model.signal(n).modality in modalities}

    def _sub_model(self, names: set[str], constraints: Sequence[ir.Constraint], extra: set[str]) -> ir.Model:
        keep = set(names) | extra
        for constraint in constraints:
            keep |= ir.mentioned_signals(constraint.expr)
        ids = {c.id for c in constraints}
        model = self.model
        return ir.Model(model.name, tuple(s for s in model.signals if s.id in keep),
                        tuple(c for c in model.constraints if c.id in ids), model.modalities, path=model.path)

    def _rules(self, enc: Encoding, question: Question) -> list[Lit]:
        skipped = {f"constraint:{question.drop}", *(f"constraint:{c}" for c in self.redundant)}
        return [literal for key, literal in enc.enable.items() if key not in skipped]

    def _local(self, question: Question, free: set[str]) -> bool:
        """CP-SAT moves only ``free`` signals; the others keep their base occurrences."""
        from mse.solve.cpsat.engine import decode

        model = self.model
        constraints = list({c.id: c for n in free for c in self.touching.get(n, ())}.values())
        modalities = {model.signal(n).modality for n in free} & model.exclusive_modalities
        mates = {n for n in self.base if model.signal(n).modality in modalities}
        sub = self._sub_model(free, constraints, mates)
        fixed = {s.id: tuple(self.base[s.id]) for s in sub.signals if s.id not in free and s.id in self.base}
        witness = slot_counts(sub, self.ticks, complete=True)
        enc = build(sub, self.ticks, {name: witness[name] for name in free}, switchable=True,
                    frame=Frame(past=fixed, committed={k: len(v) for k, v in fixed.items()}))
        extra = question.literals(enc)
        if extra is None:
            return False
        self._hint_base(enc)
        status, solver = self._solve(enc, [*self._rules(enc, question), *extra])
        if status != "feasible":
            return False
        intervals = {n: spans for n, spans in self.base.items() if n not in free}
        intervals.update(intervals_of(decode(enc, solver)))
        if question.harvest:
            self.harvest(intervals, free)
            self._remember(intervals)
        return True

    def _disproved(self, question: Question, names: set[str]) -> bool:
        """Is the question impossible under the constraints naming ``names`` alone?"""
        constraints = list({c.id: c for n in names for c in self.touching.get(n, ())}.values())
        sub = self._sub_model(names, constraints, set())
        if len(sub.signals) == len(self.model.signals):
            return False  # that is the whole set: the full model answers
        enc = build(sub, self.ticks, slot_counts(sub, self.ticks, complete=True), switchable=True)
        extra = question.literals(enc)
        if extra is None:
            return True
        self._hint_base(enc)  # the base satisfies these constraints: a feasible answer is near it
        status, _ = self._solve(enc, [*self._rules(enc, question), *extra])
        return status == "infeasible"

    def full(self) -> Encoding:
        """One switchable model of the whole set (built when first needed)."""
        if self._full is None:
            self._full = build(self.model, self.ticks, slot_counts(self.model, self.ticks, complete=True),
                               switchable=True)
            self._hint_base(self._full)
        return self._full

    def _hint_base(self, enc: Encoding) -> None:
        """Start the search from the base timeline (consistent): a question that a few changes
        to it answer is found near it at once rather than after a search from scratch (1.9 s
        of CPU for one question on 1,000 constraints before; docs/solvers.md "Lint")."""
        from mse.solve.cpsat.objective import hint

        for name, slots in enc.slots.items():
            spans = sorted(self.base.get(name, ()))
            for rank, slot in enumerate(s for s in slots if s.decided):
                start, stop = spans[rank] if rank < len(spans) else (-1, -1)
                hint(enc, slot, start, stop - start)

    def _ask_full(self, question: Question) -> str:
        from mse.solve.cpsat.engine import decode

        enc = self.full()
        extra = question.literals(enc)
        if extra is None:
            return "infeasible"
        status, solver = self._solve(enc, [*self._rules(enc, question), *extra])
        if status == "feasible" and question.harvest:
            intervals = intervals_of(decode(enc, solver))
            self.harvest(intervals)
            self._remember(intervals)
        return status

    def _solve(self, enc: Encoding, literals: Sequence[Lit]) -> tuple[str, Any]:
        from ortools.sat.python import cp_model

        from mse.solve.cpsat.engine import make_solver

        if any(lit is False for lit in literals):
            return "infeasible", None
        enc.cp.clear_assumptions()
        enc.cp.add_assumptions([lit for lit in literals if lit is not True])
        # Presolve costs ten times more than the search on these small models: try
        # without it first, and with it only when the light search runs out of time.
        # Budgets are CP-SAT deterministic time (one worker), so that lint's answers do not
        # depend on the machine's load; the wall-clock limit is only a safety net.
        for light in (True, False):
            work = self.query_time / 2 if light else self.query_time
            solver = make_solver(WALL_FACTOR * work, light=light)
            solver.parameters.max_deterministic_time = work
            status = solver.solve(enc.cp)
            if status != cp_model.UNKNOWN:
                break
        if status in (cp_model.OPTIMAL, cp_model.FEASIBLE):
            return "feasible", solver
        return ("infeasible" if status == cp_model.INFEASIBLE else "unknown"), None


def schedule_of(intervals: Mapping[str, Sequence[tuple[int, int]]], ticks: int) -> Schedule:
    return Schedule.of(ticks, (Occurrence(a, b, name) for name, spans in intervals.items() for a, b in spans))

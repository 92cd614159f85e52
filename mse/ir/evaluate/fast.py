"""The fast path of :func:`mse.ir.evaluate.check_schedule`: closures compiled once per model
recognise a consistent schedule without building any message (:func:`is_clean`).

The closures read *pools*: per signal, its occurrences as ``(start, stop)`` sorted by start,
not overlapping and of positive length -- what the per-signal rules leave, which
:meth:`_Checker.clean` checks first.  In such a pool starts and stops both increase, so the
extreme values of any edge are the first and the last occurrence's: a relation or comparison
made of bounds joined by ``and`` holds for every pair of occurrences iff each bound holds
between the extremes (O(1) instead of every pair), and "no two intervals overlap" is one
merge of the two pools (O(n + m)).  An hour of a repetitive signal has hundreds of
occurrences; every pair of two of them is ~10^5 tests.
"""

from __future__ import annotations

import itertools
import weakref
from collections.abc import Callable, Mapping, Sequence

from mse.ir import model as ir
from mse.ir.evaluate.semantics import Truth, evaluate_atom, kleene_not
from mse.ir.relations import (
    COMPARISONS,
    EDGE_INDEX,
    RELATIONS,
    Endpoint,
    compare_test,
    compiled,
    interval_test,
    is_conjunction,
    is_disjointness,
    known_time,
)
from mse.ir.schedule import Schedule, to_ticks

# -- the fast path: recognising a consistent schedule without building messages ---------------
# The sampler verifies every timeline it returns; almost all of them are consistent, so the
# common answer "no violation" is computed by closures compiled once per model.  They decide
# exactly what the full path (mse.ir.evaluate, semantics.py) decides (tests/test_greedy_check.py compares them); any
# doubt -- an unknown signal, any structural or constraint violation -- sends the schedule
# through the full path, which builds the messages.
_Pool = Sequence[tuple[int, int]]
_Node = Callable[[Mapping[str, _Pool], int], Truth]


def _compile_relation(atom: ir.Relation) -> _Node:
    holds, left, right = interval_test(atom.kind), atom.left, atom.right
    if left == right:  # one occurrence stands for both names

        def same(intervals: Mapping[str, _Pool], _duration: int) -> Truth:
            pool = intervals.get(left)
            return None if not pool else all(holds(a, a) for a in pool)

        return same
    meaning = RELATIONS[atom.kind]
    if is_conjunction(meaning) and all(b.lower.side != b.upper.side for b in meaning.bounds):
        # Every pair holds iff each bound holds between the largest value of its lower
        # endpoint and the smallest of its upper one: the last and the first occurrence.
        def extreme(position: int) -> Callable[[Endpoint], str]:
            return lambda end: f"{'a' if end.side == 'left' else 'b'}[{position}][{EDGE_INDEX[end.edge]}]"

        every = compiled("a, b", meaning.source(extreme(-1), extreme(0)))

        def extremes(intervals: Mapping[str, _Pool], _duration: int) -> Truth:
            lefts, rights = intervals.get(left), intervals.get(right)
            if not lefts or not rights:
                return None
            return bool(every(lefts, rights))

        return extremes
    if is_disjointness(meaning):

        def disjoint(intervals: Mapping[str, _Pool], _duration: int) -> Truth:
            lefts, rights = intervals.get(left), intervals.get(right)
            if not lefts or not rights:
                return None
            return _apart(lefts, rights)

        return disjoint

    def pair(intervals: Mapping[str, _Pool], _duration: int) -> Truth:
        lefts, rights = intervals.get(left), intervals.get(right)
        if not lefts or not rights:
            return None
        for a in lefts:
            for b in rights:
                if not holds(a, b):
                    return False
        return True

    return pair


def _apart(lefts: _Pool, rights: _Pool) -> bool:
    """No interval of ``lefts`` overlaps one of ``rights`` (two pools): one merge.  The one of
    the current two that stops first meets nothing later in the other pool (those start at or
    after the current one's stop), so it is passed."""
    i = j = 0
    while i < len(lefts) and j < len(rights):
        a, b = lefts[i], rights[j]
        if a[1] <= b[0]:
            i += 1
        elif b[1] <= a[0]:
            j += 1
        else:
            return False
    return True


def _reader(term: ir.Term) -> Callable[[tuple[int, int], int], int]:
    """The value of ``term`` given the chosen interval of its signal and the duration."""
    if isinstance(term, ir.SignalTime):
        index, offset = EDGE_INDEX[term.edge], term.offset
        return lambda interval, _duration: interval[index] + offset
    return lambda _interval, duration: known_time(term, duration)


def _compile_compare(atom: ir.Compare) -> _Node:
    names = tuple(dict.fromkeys(ir.atom_signals(atom)))  # the left term's signal first
    if not names:
        return lambda intervals, duration: evaluate_atom(atom, intervals, duration)
    holds, tolerance, left, right = compare_test(atom.op), atom.tolerance, _reader(atom.left), _reader(atom.right)
    if len(names) == 1:  # a signal against a constant, or against itself
        name = names[0]

        def one(intervals: Mapping[str, _Pool], duration: int) -> Truth:
            pool = intervals.get(name)
            if not pool:
                return None
            return all(holds(left(a, duration), right(a, duration), tolerance) for a in pool)

        return one
    a_name, b_name = names
    meaning = COMPARISONS[atom.op]
    if not is_conjunction(meaning):

        def pair(intervals: Mapping[str, _Pool], duration: int) -> Truth:
            lefts, rights = intervals.get(a_name), intervals.get(b_name)
            if not lefts or not rights:
                return None
            for a in lefts:
                value = left(a, duration)
                for b in rights:
                    if not holds(value, right(b, duration), tolerance):
                        return False
            return True

        return pair
    # Each term is an edge of its signal plus an offset: largest at the pool's last occurrence,
    # smallest at its first; every pair holds iff each bound holds between the extremes.
    every = compiled("lmax, lmin, rmax, rmin, tolerance",
                     meaning.source(lambda side: f"{side[0]}max", lambda side: f"{side[0]}min"))

    def two(intervals: Mapping[str, _Pool], duration: int) -> Truth:
        lefts, rights = intervals.get(a_name), intervals.get(b_name)
        if not lefts or not rights:
            return None
        return bool(every(left(lefts[-1], duration), left(lefts[0], duration),
                          right(rights[-1], duration), right(rights[0], duration), tolerance))

    return two


def _compile(expr: ir.Expr) -> _Node:
    """A closure equal to ``evaluate_expr(expr, ...)``."""
    if isinstance(expr, ir.Exists):
        name = expr.signal
        return lambda intervals, _duration: bool(intervals.get(name))
    if isinstance(expr, ir.Relation):
        return _compile_relation(expr)
    if isinstance(expr, ir.Compare):
        return _compile_compare(expr)
    if isinstance(expr, ir.Not):
        inner = _compile(expr.operand)
        return lambda intervals, duration: kleene_not(inner(intervals, duration))
    # The connectives stop at the first operand that decides (the operands are pure: the same
    # value as kleene_or / kleene_and of them all).
    if isinstance(expr, ir.Implies):
        premise, conclusion = _compile(expr.left), _compile(expr.right)

        def implies(intervals: Mapping[str, _Pool], duration: int) -> Truth:
            # kleene_or([kleene_not(premise), conclusion])
            given = premise(intervals, duration)
            if given is False:
                return True
            then = conclusion(intervals, duration)
            if then is True:
                return True
            return None if given is None or then is None else False

        return implies
    parts = tuple(_compile(e) for e in ir.children(expr))
    if isinstance(expr, ir.And):

        def conjunction(intervals: Mapping[str, _Pool], duration: int) -> Truth:
            unknown = False
            for part in parts:
                value = part(intervals, duration)
                if value is False:
                    return False
                if value is None:
                    unknown = True
            return None if unknown else True

        return conjunction

    def disjunction(intervals: Mapping[str, _Pool], duration: int) -> Truth:
        unknown = False
        for part in parts:
            value = part(intervals, duration)
            if value is True:
                return True
            if value is None:
                unknown = True
        return None if unknown else False

    return disjunction


_NO_LIMIT = 1 << 62  # stands for "unbounded": no length or count reaches it


class _Checker:
    """One model, compiled: :meth:`clean` is True iff :func:`check_schedule` finds nothing."""

    __slots__ = ("constraints", "limits")

    def __init__(self, model: ir.Model) -> None:
        exclusive = model.exclusive_modalities
        #: signal -> (shortest, longest, most occurrences, exclusive modality or None), in ticks
        self.limits: dict[str, tuple[int, int, int, str | None]] = {
            s.id: (
                to_ticks(s.min_duration),
                _NO_LIMIT if s.max_duration is None else to_ticks(s.max_duration),
                1 if not s.repetitive else _NO_LIMIT if s.max_occurrences is None else s.max_occurrences,
                s.modality if s.modality in exclusive else None,
            )
            for s in model.signals
        }
        self.constraints = tuple((tuple(c.triggers), _compile(c.expr)) for c in model.constraints)

    def clean(self, schedule: Schedule) -> bool:
        duration, limits = schedule.duration, self.limits
        grouped: dict[str, list[tuple[int, int]]] = {}
        for occurrence in schedule.occurrences:
            name, start, stop = occurrence.signal, occurrence.start, occurrence.stop
            spec = limits.get(name)
            if spec is None or not 0 <= start < stop <= duration:
                return False
            if not spec[0] <= stop - start <= spec[1]:
                return False
            pool = grouped.get(name)
            if pool is None:
                grouped[name] = [(start, stop)]
            else:
                pool.append((start, stop))
        by_modality: dict[str, list[tuple[int, int]]] = {}
        for name, pool in grouped.items():
            _, _, most, modality = limits[name]
            if len(pool) > 1:
                if len(pool) > most:
                    return False
                pool.sort()  # the pools the constraints read are sorted (the module's docstring)
                for first, second in itertools.pairwise(pool):
                    if second[0] < first[1]:
                        return False
            elif most < 1:
                return False
            if modality is not None:
                members = by_modality.get(modality)
                if members is None:
                    by_modality[modality] = pool
                else:
                    by_modality[modality] = members + pool  # a new list: pools stay as they are
        for members in by_modality.values():
            # No two occurrences of one signal overlap (checked above), so any overlap in the
            # modality is between two signals: an exclusivity violation.
            if len(members) > 1:
                reach = -1
                for start, stop in sorted(members):
                    if start < reach:
                        return False
                    if stop > reach:
                        reach = stop
        return self.constraints_hold(grouped, duration)

    def constraints_hold(self, pools: Mapping[str, _Pool], duration: int) -> bool:
        """No constraint is violated on ``pools`` (the module's docstring says what they are)."""
        for triggers, node in self.constraints:
            if triggers:
                for name in triggers:
                    if pools.get(name):
                        break
                else:
                    continue  # ignored: no trigger occurs
            if node(pools, duration) is False:
                return False
        return True


# Compiled per model object (identity: hashing a whole model per call would cost more than the
# check); the weak reference tells a reused id from the same model.
_CHECKERS: dict[int, tuple[weakref.ref[ir.Model], _Checker]] = {}
_CHECKERS_LIMIT = 256


def _checker(model: ir.Model) -> _Checker:
    entry = _CHECKERS.get(id(model))
    if entry is None or entry[0]() is not model:
        if len(_CHECKERS) >= _CHECKERS_LIMIT:
            _CHECKERS.clear()
        entry = _CHECKERS[id(model)] = (weakref.ref(model), _Checker(model))
    return entry[1]


def is_clean(model: ir.Model, schedule: Schedule) -> bool:
    """True iff :func:`check_schedule` would return no violation (fast: no messages)."""
    return _checker(model).clean(schedule)


def constraints_hold(model: ir.Model, pools: Mapping[str, _Pool], duration: int) -> bool:
    """True iff no constraint of ``model`` is violated, given each signal's occurrences as a
    pool: ``(start, stop)`` sorted, not overlapping, of positive length (the caller's promise:
    the per-signal rules of :func:`is_clean` are not checked).  For a caller that keeps its
    timeline in pools, as the chain stage does, to check a move's constraints without
    regrouping the whole timeline."""
    return _checker(model).constraints_hold(pools, duration)

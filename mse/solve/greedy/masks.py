"""Truth-value sets and their folds over possible-times boxes: the arithmetic of the greedy
sampler's partial check (partial.py; docs/sampler.md, "Checking a partial animation").

An atom evaluates to the *set* of truth values it may take, a bit mask of ``T`` (true), ``F``
(false) and ``N`` (unknown: a signal it names never occurs); strong Kleene connectives are
lifted to these sets.  Every occurrence is a box ``(start_lo, start_hi, stop_lo, stop_hi)`` of
possible times (placed occurrences are points).
"""

from __future__ import annotations

from bisect import bisect_right
from collections.abc import Callable, Mapping, Sequence
from operator import itemgetter

from mse.ir.relations import (
    COMPARISONS,
    EDGE_INDEX,
    RELATIONS,
    Endpoint,
    PerEntry,
    compiled,
    endpoint_of,
    is_conjunction,
    is_disjointness,
)

#: The truth values an atom may take, as bits of a set: true, false, unknown.
T, F, N = 1, 2, 4
#: A possible-times box: (start_lo, start_hi, stop_lo, stop_hi) in ms.
Box = tuple[int, int, int, int]
Env = Mapping[str, Sequence[Box]]
Node = Callable[[Env], int]


def mask_not(mask: int) -> int:
    return ((mask & T) << 1) | ((mask & F) >> 1) | (mask & N)


def mask_and(masks: Sequence[int]) -> int:
    every, some, true_or_unknown = T | F | N, 0, True
    for mask in masks:
        every &= mask
        some |= mask
        if not mask & (T | N):
            true_or_unknown = False
    return (every & T) | (some & F) | (N if true_or_unknown and some & N else 0)


def mask_or(masks: Sequence[int]) -> int:
    every, some, false_or_unknown = T | F | N, 0, True
    for mask in masks:
        every &= mask
        some |= mask
        if not mask & (F | N):
            false_or_unknown = False
    return (some & T) | (every & F) | (N if false_or_unknown and some & N else 0)


# Masks are 3-bit sets, so the connectives on one or two masks are table lookups (the
# partial check runs tens of thousands of times per second): NOT_TABLE[m], AND_TABLE[a << 3 | b].
NOT_TABLE = tuple(mask_not(m) for m in range(8))
AND_TABLE = tuple(mask_and((a, b)) for a in range(8) for b in range(8))
OR_TABLE = tuple(mask_or((a, b)) for a in range(8) for b in range(8))
#: ``a implies b`` is ``not a or b``.
IMPLIES_TABLE = tuple(mask_or((mask_not(a), b)) for a in range(8) for b in range(8))


# -- interval comparisons: the truth values ``a op b`` may take for a in [alo, ahi], b in
# [blo, bhi] ----------------------------------------------------------------------------------
# Every atom is bounds ``x - y <= k`` (mse.ir.relations): one may hold when the smallest x
# and the largest y satisfy it, and may fail when the largest x and the smallest y do not.
# Each relation and comparison of the table is compiled once to one expression of these (the
# hot path: no interpretation of the table per check).
def mask_source(may_true: str, may_false: str) -> str:
    """Source of the mask given the sources of "may be true" and "may be false"."""
    return f"({T} if {may_true} else 0) | ({F} if {may_false} else 0)"


def _compare_source(op: str, x: tuple[str, str], y: tuple[str, str]) -> str:
    """``x op y`` for x in [x[0], x[1]] and y in [y[0], y[1]] (sources of the ends)."""
    meaning, ends = COMPARISONS[op], {"left": x, "right": y}
    return mask_source(
        meaning.source(lambda t: ends[t][0], lambda t: ends[t][1]),
        meaning.source(lambda t: ends[t][1], lambda t: ends[t][0], negated=True),
    )


#: op -> mask of ``a op b`` for a in [alo, ahi], b in [blo, bhi]
COMPARE_MASKS: PerEntry[Callable[[int, int, int, int, int], int]] = PerEntry(
    lambda op: compiled("alo, ahi, blo, bhi, tolerance", _compare_source(op, ("alo", "ahi"), ("blo", "bhi")))
)


def compare_mask(op: str, alo: int, ahi: int, blo: int, bhi: int, tolerance: int = 0) -> int:
    return COMPARE_MASKS[op](alo, ahi, blo, bhi, tolerance)


#: Box indices of the smallest and the largest value of each edge.
LOW = {edge: 2 * index for edge, index in EDGE_INDEX.items()}
HIGH = {edge: 2 * index + 1 for edge, index in EDGE_INDEX.items()}


def relation_mask_source(kind: str, a: str = "a", b: str = "b") -> str:
    """Source of the mask of ``kind`` on one box ``a`` of the left signal and one ``b`` of
    the right (codegen.py inlines it)."""
    meaning = RELATIONS[kind]
    low, high = endpoint_of((a, b), LOW), endpoint_of((a, b), HIGH)
    return mask_source(meaning.source(low, high), meaning.source(high, low, negated=True))


#: kind -> truth values of ``kind(a, b)`` for one occurrence box of each signal
RELATION_MASKS: PerEntry[Callable[[Box, Box], int]] = PerEntry(
    lambda kind: compiled("a, b", relation_mask_source(kind))
)


def relation_mask(kind: str, a: Box, b: Box) -> int:
    """Truth values of ``kind(a, b)`` for one occurrence box of each signal."""
    return RELATION_MASKS[kind](a, b)


# -- folds over several occurrences ---------------------------------------------------------------
# A relational atom over signals with several occurrences holds for every combination of them:
# true is possible when every pair may be true, false when some pair may be false.  A
# relation that is a conjunction of bounds (mse.ir.relations) only needs the smallest and
# largest value of each box component; "no overlap" (excludes) is a sweep (or binary
# searches) over both lists; any other meaning goes pair by pair.  The components of a
# signal's boxes never decrease along its list (occurrences of one signal are placed in start
# order and never overlap; a box still to be decided comes last and starts after them), so
# the smallest and largest values are the first and last box's.  A repetitive signal may
# occur hundreds of times in a long timeline: this keeps a check's cost flat.
def _sweep_overlaps(left: Sequence[Box], right: Sequence[Box], lo: int, hi: int) -> bool:
    """Some pair has ``left[i][hi] > right[j][lo]`` and ``right[j][hi] > left[i][lo]``; both
    lists have nondecreasing components.  A merge of the two lists, or, when one is much
    shorter, a binary search in the longer one per box of the shorter (the first box of the
    longer ending after this one starts is the only one that can overlap it first)."""
    if len(left) > len(right):
        left, right, lo, hi = right, left, lo, hi
    if len(left) * 8 < len(right):
        key = itemgetter(hi)
        for box in left:
            index = bisect_right(right, box[lo], key=key)
            if index < len(right) and right[index][lo] < box[hi]:
                return True
        return False
    i = j = 0
    while i < len(left) and j < len(right):
        a, b = left[i], right[j]
        if a[hi] <= b[lo]:
            i += 1
        elif b[hi] <= a[lo]:
            j += 1
        else:
            return True
    return False


def _extreme_source(indices: Mapping[str, int], extreme: str) -> Callable[[Endpoint], str]:
    """Source of the smallest (``extreme`` "0": the first box's) or the largest ("-1": the
    last box's) value of box component ``indices[edge]`` over the boxes of one side."""
    return lambda end: f"{'left' if end.side == 'left' else 'right'}[{extreme}][{indices[end.edge]}]"


def _fold_by_extremes(kind: str) -> Callable[[Sequence[Box], Sequence[Box]], int]:
    """A conjunction of bounds holds for every pair iff it does for the extreme values:
    may be true when the largest low x and the smallest high y satisfy each bound, may be
    false when the largest high x and the smallest low y break one (the first and the last box: see above)."""
    meaning = RELATIONS[kind]
    may_true = meaning.source(_extreme_source(LOW, "-1"), _extreme_source(HIGH, "0"))
    may_false = meaning.source(_extreme_source(HIGH, "-1"), _extreme_source(LOW, "0"), negated=True)
    return compiled("left, right", mask_source(may_true, may_false))


def _fold_disjoint(left: Sequence[Box], right: Sequence[Box]) -> int:
    """"No overlap" for every pair: may be true when no pair certainly overlaps (a[stop_lo] >
    b[start_hi] and b[stop_lo] > a[start_hi]), may be false when some pair may overlap."""
    may_true = not _sweep_overlaps(left, right, HIGH["start"], LOW["stop"])
    may_false = _sweep_overlaps(left, right, LOW["start"], HIGH["stop"])
    return (T if may_true else 0) | (F if may_false else 0)


def _fold_pairwise(kind: str) -> Callable[[Sequence[Box], Sequence[Box]], int]:
    """Any other meaning, pair by pair: true possible when every pair may be, false when
    some pair may be."""
    pair = RELATION_MASKS[kind]

    def fold(left: Sequence[Box], right: Sequence[Box]) -> int:
        may_true, may_false = True, False
        for a in left:
            for b in right:
                mask = pair(a, b)
                may_true = may_true and bool(mask & T)
                may_false = may_false or bool(mask & F)
        return (T if may_true else 0) | (F if may_false else 0)

    return fold


def _fold(kind: str) -> Callable[[Sequence[Box], Sequence[Box]], int]:
    meaning = RELATIONS[kind]
    if is_conjunction(meaning):
        return _fold_by_extremes(kind)
    if is_disjointness(meaning):
        return _fold_disjoint
    return _fold_pairwise(kind)


#: kind -> truth values of ``kind`` over every pair of the boxes of two signals
RELATION_FOLDS: PerEntry[Callable[[Sequence[Box], Sequence[Box]], int]] = PerEntry(_fold)


def fold_relation(kind: str, left: Sequence[Box], right: Sequence[Box]) -> int:
    return RELATION_FOLDS[kind](left, right)


def _fold_compare_source(op: str) -> str:
    """``x op y`` for every x of ``left`` and y of ``right``, each given as (min of the low
    ends, max of the low ends, min of the high ends, max of the high ends)."""
    meaning = COMPARISONS[op]

    def end(index: int) -> Callable[[str], str]:
        return lambda term: f"{'a' if term == 'left' else 'b'}[{index}]"

    return mask_source(meaning.source(end(1), end(2)), meaning.source(end(3), end(0), negated=True))


#: op -> truth values of ``x op y`` for every x and y (see :func:`fold_compare`)
COMPARE_FOLDS: PerEntry[Callable[[tuple[int, int, int, int], tuple[int, int, int, int], int], int]] = PerEntry(
    lambda op: compiled("a, b, tolerance", _fold_compare_source(op))
)


def fold_compare(op: str, left: tuple[int, int, int, int], right: tuple[int, int, int, int], tolerance: int) -> int:
    """``x op y`` for every x of ``left`` and y of ``right``, each given as (min of the low
    ends, max of the low ends, min of the high ends, max of the high ends)."""
    return COMPARE_FOLDS[op](left, right, tolerance)


def edge_span(boxes: Sequence[Box], low: int, high: int, offset: int) -> tuple[int, int, int, int]:
    """(min low, max low, min high, max high) of one edge: first and last box (see above)."""
    first, last = boxes[0], boxes[-1]
    return first[low] + offset, last[low] + offset, first[high] + offset, last[high] + offset


def for_each_pair(pairs_mask: Callable[[Box, Box], int], boxes: Sequence[Box]) -> int:
    """Fold over the pairs (box, box): an atom naming one signal twice (same occurrence)."""
    may_true, may_false = True, False
    for box in boxes:
        mask = pairs_mask(box, box)
        may_true = may_true and bool(mask & T)
        may_false = may_false or bool(mask & F)
    return (T if may_true else 0) | (F if may_false else 0)

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
def compare_mask(op: str, alo: int, ahi: int, blo: int, bhi: int, tolerance: int = 0) -> int:
    if op == "<=":
        return (T if alo <= bhi else 0) | (F if ahi > blo else 0)
    if op == "<":
        return (T if alo < bhi else 0) | (F if ahi >= blo else 0)
    if op == ">=":
        return (T if ahi >= blo else 0) | (F if alo < bhi else 0)
    if op == ">":
        return (T if ahi > blo else 0) | (F if alo <= bhi else 0)
    low, high = alo - bhi, ahi - blo  # the range of a - b
    may_true = low <= tolerance and high >= -tolerance
    may_false = low < -tolerance or high > tolerance
    return (T if may_true else 0) | (F if may_false else 0)


def _precedes(a: Box, b: Box) -> int:
    return (T if a[2] <= b[1] else 0) | (F if a[3] > b[0] else 0)


# Each relation below is two interval comparisons ``x <= y`` (T if lo(x) <= hi(y), F if
# hi(x) > lo(y)) joined by "and" (T needs both, F either) or "or" (T needs either, F both),
# written out because this is the hot path.
def _includes(a: Box, b: Box) -> int:
    # start(a) <= start(b) and stop(b) <= stop(a)
    return (T if a[0] <= b[1] and b[2] <= a[3] else 0) | (F if a[1] > b[0] or b[3] > a[2] else 0)


def _excludes(a: Box, b: Box) -> int:
    # stop(a) <= start(b) or stop(b) <= start(a)
    return (T if a[2] <= b[1] or b[2] <= a[1] else 0) | (F if a[3] > b[0] and b[3] > a[0] else 0)


def _rightincludes(a: Box, b: Box) -> int:
    # start(a) <= stop(b) and stop(b) <= stop(a)
    return (T if a[0] <= b[3] and b[2] <= a[3] else 0) | (F if a[1] > b[2] or b[3] > a[2] else 0)


RELATION_MASKS: dict[str, Callable[[Box, Box], int]] = {
    "precedes": _precedes,
    "includes": _includes,
    "excludes": _excludes,
    "rightincludes": _rightincludes,
}


def relation_mask(kind: str, a: Box, b: Box) -> int:
    """Truth values of ``kind(a, b)`` for one occurrence box of each signal."""
    return RELATION_MASKS[kind](a, b)


# -- folds over several occurrences ---------------------------------------------------------------
# A relational atom over signals with several occurrences holds for every combination of them:
# true is possible when every pair may be true, false when some pair may be false.  Each
# relation but excludes is a conjunction of ``x <= y`` comparisons, so the fold only needs the
# smallest and largest value of each box component; excludes is a sweep (or binary searches)
# over both lists.  The components of a signal's boxes never decrease along its list
# (occurrences of one signal are placed in start order and never overlap; a box still to be
# decided comes last and starts after them), so the smallest and largest values are the
# first and last box's.  A repetitive signal may occur hundreds of times in a long timeline:
# this keeps a check's cost flat.
def _spans(boxes: Sequence[Box]) -> tuple[tuple[int, int], tuple[int, int], tuple[int, int], tuple[int, int]]:
    """(min, max) of each of the four box components: the first and the last box's, since the
    components never decrease along the list (see above)."""
    first, last = boxes[0], boxes[-1]
    return (first[0], last[0]), (first[1], last[1]), (first[2], last[2]), (first[3], last[3])


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


def fold_relation(kind: str, left: Sequence[Box], right: Sequence[Box]) -> int:
    if kind == "excludes":
        # T: no pair with a[2] > b[1] and b[2] > a[1]; F: some pair with a[3] > b[0] and b[3] > a[0]
        may_true = not _sweep_overlaps(left, right, 1, 2)
        may_false = _sweep_overlaps(left, right, 0, 3)
        return (T if may_true else 0) | (F if may_false else 0)
    a, b = _spans(left), _spans(right)
    if kind == "precedes":  # a.stop <= b.start
        return (T if a[2][1] <= b[1][0] else 0) | (F if a[3][1] > b[0][0] else 0)
    if kind == "includes":  # a.start <= b.start and b.stop <= a.stop
        return ((T if a[0][1] <= b[1][0] and b[2][1] <= a[3][0] else 0)
                | (F if a[1][1] > b[0][0] or b[3][1] > a[2][0] else 0))
    # rightincludes: a.start <= b.stop and b.stop <= a.stop
    return ((T if a[0][1] <= b[3][0] and b[2][1] <= a[3][0] else 0)
            | (F if a[1][1] > b[2][0] or b[3][1] > a[2][0] else 0))


def fold_compare(op: str, left: tuple[int, int, int, int], right: tuple[int, int, int, int], tolerance: int) -> int:
    """``x op y`` for every x of ``left`` and y of ``right``, each given as (min of the low
    ends, max of the low ends, min of the high ends, max of the high ends)."""
    a_min_lo, a_max_lo, a_min_hi, a_max_hi = left
    b_min_lo, b_max_lo, b_min_hi, b_max_hi = right
    if op == "<=":
        return (T if a_max_lo <= b_min_hi else 0) | (F if a_max_hi > b_min_lo else 0)
    if op == "<":
        return (T if a_max_lo < b_min_hi else 0) | (F if a_max_hi >= b_min_lo else 0)
    if op == ">=":
        return (T if a_min_hi >= b_max_lo else 0) | (F if a_min_lo < b_max_hi else 0)
    if op == ">":
        return (T if a_min_hi > b_max_lo else 0) | (F if a_min_lo <= b_max_hi else 0)
    may_true = a_max_lo - b_min_hi <= tolerance and a_min_hi - b_max_lo >= -tolerance
    may_false = a_min_lo - b_max_hi < -tolerance or a_max_hi - b_min_lo > tolerance
    return (T if may_true else 0) | (F if may_false else 0)


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

"""Sets of ticks as sorted inclusive intervals: the ad-hoc inference of the greedy sampler.

A check over one variable tick (a start or a stop) changes its answer only at *critical
points*: where some comparison with a known time flips.  :func:`feasible` probes every point
and one tick inside every open segment between two of them, which gives the exact allowed set
for the exact comparisons (docs/sampler.md, "Placing one candidate").
"""

from __future__ import annotations

import random
from collections.abc import Callable, Iterable, Mapping, Sequence

from mse.solve.greedy.edges import Edge
from mse.solve.greedy.plan import CriticalRules, SignalPlan

Intervals = list[tuple[int, int]]


def critical_points(
    edges: Iterable[Edge],
    env: Mapping[str, Sequence[tuple[int, int, int, int]]],
    signal: SignalPlan,
    variable: str,
    start: int | None,
) -> list[int]:
    """Values of the drawn edge of ``signal`` (``variable``: "start" or "stop", the start
    being ``start`` when the stop is drawn) at which some comparison of ``edges`` with the
    placed boxes of ``env`` may flip."""
    points: list[int] = []
    for edge in edges:
        if edge.other_signal is None:
            values = [edge.other_offset]
        elif edge.other_signal == signal.id:
            if start is None or edge.other_edge != "start":
                continue
            values = [start + edge.other_offset]
        else:
            boxes = env.get(edge.other_signal, ())
            index = 0 if edge.other_edge == "start" else 2
            values = [box[index] + edge.other_offset for box in boxes]
            # a range (an open-stop trial, engine.open_stop_may_pay): both of its ends
            values += [box[index + 1] + edge.other_offset for box in boxes if box[index + 1] != box[index]]
        shifts = [0]
        if variable == "start" and edge.my_edge == "stop":
            shifts = [signal.shortest, signal.longest]
        elif variable != edge.my_edge:
            continue
        for value in values:
            pivot = value - edge.my_offset
            for shift in shifts:
                for delta in (-edge.tolerance - 1, -edge.tolerance, edge.tolerance, edge.tolerance + 1):
                    points.append(pivot - shift + delta)
    return points


def critical_rules(edges: Iterable[Edge], signal: SignalPlan, variable: str) -> CriticalRules:
    """:func:`critical_points` compiled once per plan: for each kind of value (a constant, the
    candidate's own start, an edge of a partner's boxes) the offsets to add to it.  The
    callers only use the points as a set, so :func:`critical_values` gives the same set."""
    constant: set[int] = set()
    own: set[int] = set()
    partners: dict[tuple[str, int], set[int]] = {}
    for edge in edges:
        shifts = [0]
        if variable == "start" and edge.my_edge == "stop":
            shifts = [signal.shortest, signal.longest]
        elif variable != edge.my_edge:
            continue
        tolerance = edge.tolerance
        offsets = {
            edge.other_offset - edge.my_offset - shift + delta
            for shift in shifts
            for delta in (-tolerance - 1, -tolerance, tolerance, tolerance + 1)
        }
        if edge.other_signal is None:
            constant |= offsets
        elif edge.other_signal == signal.id:
            if edge.other_edge == "start":
                own |= offsets
        else:
            index = 0 if edge.other_edge == "start" else 2
            partners.setdefault((edge.other_signal, index), set()).update(offsets)
    return (
        tuple(sorted(constant)),
        tuple(sorted(own)),
        tuple((other, index, tuple(sorted(offsets))) for (other, index), offsets in partners.items()),
    )


def critical_values(
    rules: CriticalRules, env: Mapping[str, Sequence[tuple[int, int, int, int]]], start: int | None
) -> list[int]:
    """The points of :func:`critical_points` (as a set: perhaps in another order, repeated)."""
    constant, own, partners = rules
    points = list(constant)
    if start is not None and own:
        points += [start + offset for offset in own]
    for other, index, offsets in partners:
        boxes = env.get(other)
        if not boxes:
            continue
        for box in boxes:
            low, high = box[index], box[index + 1]
            points += [low + offset for offset in offsets]
            if high != low:  # a range (an open-stop trial): both of its ends
                points += [high + offset for offset in offsets]
    return points


def feasible(check: Callable[[int], bool], low: int, high: int, points: Iterable[int]) -> Intervals:
    """The ticks of [low, high] where ``check`` holds, as inclusive intervals.

    ``points`` are the critical values where a comparison may change truth; between two of
    them every exact comparison is constant, so one probe stands for the open segment."""
    probes = sorted({p for p in points if low < p < high} | {low, high})
    found: Intervals = []

    def add(first: int, last: int) -> None:
        if found and found[-1][1] + 1 >= first:
            found[-1] = (found[-1][0], last)
        else:
            found.append((first, last))

    previous: int | None = None
    for point in probes:
        if previous is not None and point - previous > 1 and check((previous + point) // 2):
            add(previous + 1, point - 1)
        if check(point):
            add(point, point)
        previous = point
    return found


def latest_feasible(
    check: Callable[[int], bool],
    low: int,
    high: int,
    points: Callable[[], Iterable[int]],
    box: Callable[[int, int], bool] | None = None,
) -> int | None:
    """The largest tick of [low, high] where ``check`` holds (probing from the end), or None.
    ``points`` (the critical values) are only computed when ``high`` itself fails.

    ``box(a, b)``: a check of every value of [a, b] at once that fails only when no value can
    pass (the partial check is monotone in boxes).  With it, the cells are searched by halves,
    and a half whose box fails is skipped: the same answer as probing every cell from the top,
    with far fewer probes when the answer is low or absent."""
    if check(high):
        return high
    values = sorted({p for p in points() if low < p < high} | {low, high}, reverse=True)
    cells: list[tuple[int, int, int]] = []  # (probe, answer, lowest value of the cell), descending
    previous: int | None = None
    for point in values:
        if previous is not None and previous - point > 1:
            cells.append(((previous + point) // 2, previous - 1, point + 1))
        if point != high:
            cells.append((point, point, point))
        previous = point

    def scan(first: int, last: int) -> int | None:
        if box is None or last - first <= 3:
            for probe, answer, _ in cells[first:last]:
                if check(probe):
                    return answer
            return None
        if not box(cells[last - 1][2], cells[first][1]):
            return None
        middle = (first + last) // 2
        found = scan(first, middle)
        return found if found is not None else scan(middle, last)

    return scan(0, len(cells))


def nearest_feasible(
    check: Callable[[int], bool], low: int, high: int, points: Iterable[int], target: int
) -> int | None:
    """``nearest(feasible(check, low, high, points), target)`` without probing more than
    needed: the cells of :func:`feasible` (each critical point, and each open segment between
    two, probed at its middle) are probed in order of their distance to ``target``, ties to
    the lower value, and the first that passes gives the answer.  None if none passes."""
    ordered = sorted({p for p in points if low < p < high} | {low, high})
    cells: list[tuple[int, int, int]] = []  # (distance to target, nearest value, probe)
    for point, following in zip(ordered, [*ordered[1:], None], strict=True):
        cells.append((abs(point - target), point, point))
        if following is not None and following - point > 1:
            value = min(max(target, point + 1), following - 1)
            cells.append((abs(value - target), value, (point + following) // 2))
    cells.sort()
    for _, value, probe in cells:
        if check(probe):
            return value
    return None


def pick_uniform(rng: random.Random, intervals: Intervals) -> int:
    total = sum(last - first + 1 for first, last in intervals)
    index = rng.randrange(total)
    for first, last in intervals:
        size = last - first + 1
        if index < size:
            return first + index
        index -= size
    raise AssertionError("unreachable")


def nearest(intervals: Intervals, value: int) -> int:
    best, distance = intervals[0][0], abs(intervals[0][0] - value)
    for first, last in intervals:
        candidate = min(max(value, first), last)
        if abs(candidate - value) < distance:
            best, distance = candidate, abs(candidate - value)
    return best


def probes(window: Intervals, per_interval: int = 4) -> list[int]:
    """A few evenly spread ticks of each interval (ends included)."""
    found: set[int] = set()
    for first, last in window:
        for i in range(per_interval + 1):
            found.add(first + (last - first) * i // per_interval)
    return sorted(found)

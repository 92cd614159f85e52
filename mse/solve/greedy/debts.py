"""Small pieces of the obligations of a walk (docs/sampler.md, "Obligations that only the
end settles"), shared by engine.py and walk.py without an import cycle."""

from __future__ import annotations

from collections.abc import Callable, Iterable

from mse.solve.greedy.windows import latest_feasible


class Doomed(Exception):
    """An obligation can no longer be met: give up this walk from here (backtrack)."""


def latest_start(
    check: Callable[[int], bool],
    points: Callable[[], Iterable[int]],
    low: int,
    high: int,
    previous: int,
    box: Callable[[int, int], bool] | None = None,
) -> int | None:
    """The latest start in [low, high] that ``check`` allows.  Placements rarely move a latest
    start later: probe below the ``previous`` one first, and the rest only when that fails."""
    latest = latest_feasible(check, low, min(previous, high), points, box) if low <= previous else None
    if latest is None and previous < high:
        latest = latest_feasible(check, max(low, previous + 1), high, points, box)
    return latest

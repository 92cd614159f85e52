"""Balanced Latin squares: orders in which every item is seen once at every position and
every item follows every other equally often (carry-over effects balanced).

For an even number of items, the Williams square: row ``r`` is ``r, r+1, r-1, r+2, r-2, …``
(mod n), so that each ordered pair of neighbours occurs exactly once.  For an odd number
no such square exists; Williams' design then takes that square and each of its rows
reversed (2n rows), in which each ordered pair of neighbours occurs exactly twice.
"""

from __future__ import annotations


def _first_row(n: int) -> list[int]:
    """0, 1, n-1, 2, n-2, …: the differences between neighbours are all distinct mod n."""
    row, low, high = [0], 1, n - 1
    for position in range(1, n):
        if position % 2:
            row.append(low)
            low += 1
        else:
            row.append(high)
            high -= 1
    return row


def balanced_latin_square(n: int) -> list[list[int]]:
    """The rows of a balanced Latin square of ``n`` items (0 … n-1): ``n`` rows for even n,
    ``2n`` rows (Williams' design) for odd n.  Participant ``p`` takes row ``p % len(rows)``."""
    if n < 1:
        raise ValueError(f"a Latin square needs at least one item (got {n})")
    first = _first_row(n)
    rows = [[(item + shift) % n for item in first] for shift in range(n)]
    if n % 2:
        rows += [list(reversed(row)) for row in rows]
    return rows

"""The order of conditions per participant: a balanced Latin square (Williams, 1949).

Every condition comes at every position equally often and, for an even number of conditions, follows every other
condition exactly once, so that order and carry-over effects cancel across a multiple of the square's rows; for an
odd number the square and its mirror image are used (2n rows).
"""

from __future__ import annotations

from collections.abc import Sequence


def williams(n: int) -> list[list[int]]:
    """The rows of a balanced Latin square of ``n`` conditions (indices 0..n-1)."""
    if n < 1:
        raise ValueError("a Latin square needs at least one condition")
    # The first row 0, 1, n-1, 2, n-2, ...; each next row adds 1 modulo n.
    first = [0]
    low, high = 1, n - 1
    for k in range(1, n):
        if k % 2 == 1:
            first.append(low)
            low += 1
        else:
            first.append(high)
            high -= 1
    rows = [[(c + r) % n for c in first] for r in range(n)]
    if n % 2 == 1:
        rows += [list(reversed(row)) for row in rows]
    return rows


def latin_orders(participants: Sequence[str], conditions: Sequence[str]) -> list[tuple[str, tuple[str, ...]]]:
    """Each participant's conditions in order: participant i takes row i of the square, cyclically."""
    rows = williams(len(conditions))
    return [(p, tuple(conditions[c] for c in rows[i % len(rows)])) for i, p in enumerate(participants)]

"""Objects of two surveys matched one to one: after the registration, the assignment of
least total distance among pairs no farther apart than a unit may have moved."""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

__all__ = ["match_objects"]


def match_objects(before_xy: np.ndarray, after_xy: np.ndarray, *, max_move: float) -> list[tuple[int, int]]:
    """Pairs ``(i, j)`` of a before object and an after object (positions in one frame).

    The assignment minimises the total distance over all pairs at once, so two units that
    swapped places, or a unit that moved next to a neighbour, keep their own partners;
    pairs farther apart than ``max_move`` are never made (the unit is reported removed and
    the other new).

    Examples
    --------
    >>> b = np.array([[0.0, 0.0], [5.0, 0.0], [20.0, 0.0]])
    >>> a = np.array([[5.4, 0.0], [1.9, 0.0], [40.0, 0.0]])
    >>> match_objects(b, a, max_move=3.0)
    [(0, 1), (1, 0)]
    """
    if not len(before_xy) or not len(after_xy):
        return []
    d = np.hypot(*(np.asarray(before_xy)[:, None, :2] - np.asarray(after_xy)[None, :, :2]).transpose(2, 0, 1))
    big = 1e9
    cost = np.where(d <= max_move, d, big)
    rows, cols = linear_sum_assignment(cost)
    return sorted((int(i), int(j)) for i, j in zip(rows, cols, strict=True) if cost[i, j] < big)

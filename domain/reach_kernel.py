"""Compiled flood fill of the lattice's free configurations: is the start's component the one
with the head on the goal?

``domain.lattice_reach`` labels every free configuration of the lattice (one comparison per
body point and orientation over the whole grid, then ``scipy.ndimage.label``) and compares the
start's component with the goal's. A question asks about two components only, so this kernel
floods from both ends at once (from the start, and from every free configuration with the head
on the goal), always growing the side that has met fewer, deciding whether a configuration is
free the first time either side meets it. It stops when the sides meet (reachable) or one side
runs out (not): the cost is about twice the smaller component, and a goal in a small pen or a
robot boxed in is decided at once. The same relaxation, the same comparisons value for value
and the same neighbours (8 cells at one orientation, one orientation step in place, orientation
wrapping round), so the answer is the labelling's (``tests/domain/test_reach_kernel.py``).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from domain.occupancy_kernel import AVAILABLE, _jit
from sim.robot import Array

__all__ = ["AVAILABLE", "configuration_free", "flood_reaches"]


def configuration_free(
    clear: Array,
    shifts: NDArray[np.int64],
    thresholds: Array,
    counts: NDArray[np.int64],
    k: int,
    i: int,
    j: int,
) -> bool:
    """Whether the resting body at bin ``k`` on cell (i, j) keeps every point's threshold
    (``shifts`` ``[K, U, 2]`` cell offsets of its points and ``thresholds`` ``[K, U]`` the
    clearance each needs there; ``counts[k]`` rows used, -1 for a bin whose body leaves any
    grid); a point off the grid is outside the arena."""
    return bool(_free(clear, shifts, thresholds, counts, k, i, j))


def flood_reaches(
    clear: Array,
    shifts: NDArray[np.int64],
    thresholds: Array,
    counts: NDArray[np.int64],
    heads: Array,
    xs: Array,
    ys: Array,
    goal: tuple[float, float],
    limit: float,
    starts: NDArray[np.int64],
) -> bool:
    """Whether a free configuration connected to one of ``starts`` (numbers ``(k * nx + i) *
    ny + j``) has its head (cell centre ``xs[i], ys[j]`` + ``heads[k]``) within ``limit`` of
    ``goal``."""
    return bool(
        _flood(clear, shifts, thresholds, counts, heads, xs, ys, goal[0], goal[1], limit, starts)
    )


@_jit
def _free(  # pragma: no cover - compiled
    clear: Array,
    shifts: NDArray[np.int64],
    thresholds: Array,
    counts: NDArray[np.int64],
    k: int,
    i: int,
    j: int,
) -> bool:
    nx, ny = clear.shape
    n = counts[k]
    if n < 0:
        return False
    for u in range(n):
        a, b = i + shifts[k, u, 0], j + shifts[k, u, 1]
        if a < 0 or a >= nx or b < 0 or b >= ny:
            return False
        if not clear[a, b] >= thresholds[k, u]:
            return False
    return True


FROM_START, FROM_GOAL, FREE, BLOCKED = 1, 2, 4, 8  # bits per configuration


@_jit
def _flood(  # pragma: no cover - compiled
    clear: Array,
    shifts: NDArray[np.int64],
    thresholds: Array,
    counts: NDArray[np.int64],
    heads: Array,
    xs: Array,
    ys: Array,
    gx: float,
    gy: float,
    limit: float,
    starts: NDArray[np.int64],
) -> bool:
    nx, ny = clear.shape
    K = counts.shape[0]
    plane = nx * ny
    seen = np.zeros(K * plane, dtype=np.uint8)
    sides = (FROM_START, FROM_GOAL)
    stacks = [np.empty(1024, dtype=np.int64), np.empty(1024, dtype=np.int64)]
    tops = np.zeros(2, dtype=np.int64)
    met = np.zeros(2, dtype=np.int64)  # configurations each side has met
    for s in starts:
        if seen[s] == 0:
            seen[s] = FROM_START | FREE
            stacks[0] = _push(stacks[0], tops, 0, s)
    # The other side: every free configuration with the head on the goal.
    for k in range(K):
        i0 = max(0, np.searchsorted(xs, gx - heads[k, 0] - limit) - 1)
        i1 = min(nx, np.searchsorted(xs, gx - heads[k, 0] + limit) + 1)
        j0 = max(0, np.searchsorted(ys, gy - heads[k, 1] - limit) - 1)
        j1 = min(ny, np.searchsorted(ys, gy - heads[k, 1] + limit) + 1)
        for i in range(i0, i1):
            for j in range(j0, j1):
                if math.hypot(xs[i] + heads[k, 0] - gx, ys[j] + heads[k, 1] - gy) > limit:
                    continue
                if not _free(clear, shifts, thresholds, counts, k, i, j):
                    continue
                m = (k * nx + i) * ny + j
                if seen[m] & FROM_START:
                    return True  # the start is on the goal already
                if seen[m] == 0:
                    seen[m] = FROM_GOAL | FREE
                    stacks[1] = _push(stacks[1], tops, 1, m)
    # Grow the side that has met fewer configurations until the sides meet (connected) or
    # one side runs out (its whole component met without the other: not connected).
    while tops[0] > 0 and tops[1] > 0:
        side = 0 if met[0] <= met[1] else 1
        mine, other = sides[side], sides[1 - side]
        tops[side] -= 1
        number = stacks[side][tops[side]]
        met[side] += 1
        k = number // plane
        cell = number - k * plane
        i = cell // ny
        j = cell - i * ny
        for step in range(10):  # 8 cells around at this bin, then one bin either way
            if step < 8:
                di = (-1, -1, -1, 0, 0, 1, 1, 1)[step]
                dj = (-1, 0, 1, -1, 1, -1, 0, 1)[step]
                a, b, c = i + di, j + dj, k
                if a < 0 or a >= nx or b < 0 or b >= ny:
                    continue
            else:
                a, b = i, j
                c = (k + (1 if step == 8 else K - 1)) % K
            m = (c * nx + a) * ny + b
            flags = seen[m]
            if flags & (mine | BLOCKED):
                continue
            if flags & other:
                return True
            if not flags & FREE and not _free(clear, shifts, thresholds, counts, c, a, b):
                seen[m] = BLOCKED
                continue
            seen[m] = flags | FREE | mine
            stacks[side] = _push(stacks[side], tops, side, m)
    return False


@_jit
def _push(  # pragma: no cover - compiled
    stack: NDArray[np.int64], tops: NDArray[np.int64], side: int, value: int
) -> NDArray[np.int64]:
    """``stack`` with ``value`` on top (grown when full); ``tops[side]`` counts its entries."""
    top = tops[side]
    if top == stack.shape[0]:
        grown = np.empty(2 * top, dtype=np.int64)
        grown[:top] = stack
        stack = grown
    stack[top] = value
    tops[side] = top + 1
    return stack

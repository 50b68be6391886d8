"""Compiled flood fill of the lattice's free configurations: is the start's component the one
with the head on the goal?

``domain.navigation.feasibility`` can label every free configuration of the lattice (one
comparison per body point and orientation over the whole grid, then ``scipy.ndimage.label``)
and compare the start's component with the goal's. A question asks about two components only,
so this kernel
floods from both ends at once (from the start, and from every free configuration with the head
on the goal), always growing the side that has met fewer, each nearest-first towards the other
(a heap on the distance to it), deciding whether a configuration is free the first time either
side meets it. It stops when the sides meet (reachable: after little more than the way
between) or one side runs out (not: a goal in a small pen or a robot boxed in is decided at
once). Two large components that do not connect cost a flood more than the labelling, so past
a budget of configurations it hands the question back. The same relaxation, the same
comparisons value for value and the same neighbours (8 cells at one orientation, one
orientation step in place, orientation wrapping round), so the answer is the labelling's
(``tests/domain/test_feasibility.py``).
"""

from __future__ import annotations

import heapq
import math

import numpy as np
from numpy.typing import NDArray

from domain.kernels import AVAILABLE, jit
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
    budget: int,
) -> bool | None:
    """Whether a free configuration connected to one of ``starts`` (numbers ``(k * nx + i) *
    ny + j``) has its head (cell centre ``xs[i], ys[j]`` + ``heads[k]``) within ``limit`` of
    ``goal``; ``None`` when the sides met ``budget`` configurations without an answer (two
    large components: labelling them all at once is cheaper then)."""
    found = _flood(
        clear, shifts, thresholds, counts, heads, xs, ys, goal[0], goal[1], limit, starts, budget
    )
    return None if found < 0 else bool(found)


@jit
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


@jit
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
    budget: int,
) -> int:
    nx, ny = clear.shape
    K = counts.shape[0]
    plane = nx * ny
    seen = np.zeros(K * plane, dtype=np.uint8)
    cell = starts[0] % plane
    sx, sy = xs[cell // ny], ys[cell % ny]  # where the goal side heads for
    from_start = [(0.0, starts[0])]  # (distance to the other side, configuration) heaps
    from_start.pop()
    from_goal = [(0.0, starts[0])]
    from_goal.pop()
    for s in starts:
        if seen[s] == 0:
            seen[s] = FROM_START | FREE
            k, c = s // plane, s % plane
            d = math.hypot(xs[c // ny] + heads[k, 0] - gx, ys[c % ny] + heads[k, 1] - gy)
            heapq.heappush(from_start, (d, s))
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
                    return 1  # the start is on the goal already
                if seen[m] == 0:
                    seen[m] = FROM_GOAL | FREE
                    heapq.heappush(from_goal, (math.hypot(xs[i] - sx, ys[j] - sy), m))
    # Grow the side that has met fewer configurations, each towards the other (nearest
    # first), until the sides meet (connected) or one side runs out: it met its whole
    # component, in whatever order, without the other (not connected).
    met_start = met_goal = 0
    while len(from_start) > 0 and len(from_goal) > 0:
        if met_start + met_goal >= budget:
            return -1
        start_side = met_start <= met_goal
        if start_side:
            met_start += 1
        else:
            met_goal += 1
        heap = from_start if start_side else from_goal
        mine, other = (FROM_START, FROM_GOAL) if start_side else (FROM_GOAL, FROM_START)
        tx, ty = (gx, gy) if start_side else (sx, sy)
        number = heapq.heappop(heap)[1]
        if _grow(
            clear, shifts, thresholds, counts, heads, xs, ys, seen, number, mine, other, tx, ty,
            start_side, heap,
        ):  # fmt: skip
            return 1
    return 0


@jit
def _grow(  # pragma: no cover - compiled
    clear: Array,
    shifts: NDArray[np.int64],
    thresholds: Array,
    counts: NDArray[np.int64],
    heads: Array,
    xs: Array,
    ys: Array,
    seen: NDArray[np.uint8],
    number: int,
    mine: int,
    other: int,
    tx: float,
    ty: float,
    by_head: bool,
    heap: list[tuple[float, int]],
) -> bool:
    """Push the free neighbours of ``number`` not yet met by this side (``mine``) onto its
    heap, by their distance to (``tx``, ``ty``) (of the head, or of the centroid's cell);
    ``True`` when one was met by the other side."""
    nx, ny = clear.shape
    K = counts.shape[0]
    plane = nx * ny
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
        x, y = xs[a], ys[b]
        if by_head:
            x, y = x + heads[c, 0], y + heads[c, 1]
        heapq.heappush(heap, (math.hypot(x - tx, y - ty), m))
    return False

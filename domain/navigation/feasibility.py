"""The one feasibility check: whether the lethal layer proves a goal out of the body's reach.

Soft costs never end a mission; only hard facts do, and two prove a goal unreachable:

- the heuristic's 2-D map has no way from the start's cell (the centroid alone cannot pass:
  ``domain.navigation.search.heuristic``), or
- the start's component of the lattice's **free configurations** holds none with the head on
  the goal: a configuration (cell, heading) is free when the resting body keeps its clearance
  less the half cell diagonal a point may sit off the centre it is rounded to, and neighbouring
  free configurations (8 cells around at one heading, or one heading step in place) connect.
  Every lattice motion joins configurations this relaxation also joins, so a goal outside the
  start's component cannot be reached by any plan (the converse need not hold: a body that
  fits everywhere along a way may still lack the motions to take it).

The second answers by a compiled flood from both ends (``flood``), stopping when they meet,
within a budget of configurations, else by labelling every free configuration.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from domain.navigation import flood
from domain.navigation.lattice.grid import Key, LatticeGrid
from domain.navigation.lattice.motions import MotionTable
from sim.robot import Array

FLOOD_BUDGET = 200_000  # configurations a flood meets before the labelling answers instead


class BodyRows(NamedTuple):
    """The resting body per orientation bin, as the flood reads it."""

    shifts: NDArray[np.int64]  # [K, U, 2] distinct cell offsets of the body's points
    thresholds: Array  # [K, U] the clearance each needs there
    counts: NDArray[np.int64]  # [K] rows used per bin (-1: the body reaches past any grid)


_ROWS: dict[tuple[int, float, int, float], tuple[MotionTable, BodyRows]] = {}
ROWS_KEPT = 16  # tables whose rows are kept (they depend on the table, never on the world)


def body_rows(grid: LatticeGrid, table: MotionTable, margin: float) -> BodyRows:
    """Per bin, the resting body's distinct cell offsets and the clearance each needs there
    (the largest need rounded into it + ``margin`` - half a cell diagonal), and how many rows
    each bin uses. Made once per table and lattice and shared: not to be written."""
    key = (id(table), grid.settings.resolution, grid.settings.orientations, margin)
    got = _ROWS.get(key)
    if got is not None and got[0] is table:
        return got[1]
    r = grid.settings.resolution
    pad = max(1, math.ceil(table.geometry.body_length / r) + 2)
    slack = r * math.sqrt(0.5)
    K = grid.settings.orientations
    rows = []
    for k in range(K):
        shifts = np.rint(table.body_points[k] / r).astype(np.int64)
        # One comparison per distinct cell shift, against the largest need rounded into it.
        unique, inverse = np.unique(shifts, axis=0, return_inverse=True)
        needs = np.full(len(unique), -np.inf)
        np.maximum.at(needs, inverse.ravel(), table.body_needs[k])
        rows.append((unique, needs + margin - slack))
    width = max(len(u) for u, _ in rows)
    shifts_out = np.zeros((K, width, 2), dtype=np.int64)
    thresholds = np.full((K, width), -np.inf)
    counts = np.empty(K, dtype=np.int64)
    for k, (unique, need) in enumerate(rows):
        shifts_out[k, : len(unique)], thresholds[k, : len(unique)] = unique, need
        counts[k] = -1 if np.any(np.abs(unique) >= pad) else len(unique)
    out = BodyRows(shifts_out, thresholds, counts)
    if len(_ROWS) >= ROWS_KEPT:
        _ROWS.clear()
    _ROWS[key] = (table, out)
    return out


def free_configurations(
    grid: LatticeGrid, table: MotionTable, clear: Array, rows: BodyRows
) -> NDArray[np.bool_]:
    """``[K, nx, ny]``: where the resting body may lie (relaxed by half a cell diagonal), from
    the lethal clearance at the cell centres ``clear`` ``[nx, ny]``."""
    nx, ny = grid.nx, grid.ny
    pad = max(1, math.ceil(table.geometry.body_length / grid.settings.resolution) + 2)
    free = np.ones((grid.settings.orientations, nx, ny), dtype=bool)
    # Padded with -inf: a body point off the grid is outside the arena.
    padded = np.full((nx + 2 * pad, ny + 2 * pad), -np.inf)
    padded[pad : pad + nx, pad : pad + ny] = clear
    shifts, thresholds, counts = rows
    for k, n in enumerate(counts.tolist()):
        part = free[k]
        if n < 0:
            part[...] = False
            continue
        for (di, dj), need in zip(shifts[k, :n], thresholds[k, :n], strict=True):
            part &= padded[pad + di : pad + di + nx, pad + dj : pad + dj + ny] >= need
    return free


# The 8 neighbouring cells at one orientation, and one orientation step in place.
NEIGHBOURS = np.zeros((3, 3, 3), dtype=bool)
NEIGHBOURS[1] = True
NEIGHBOURS[0, 1, 1] = NEIGHBOURS[2, 1, 1] = True


def components(free: NDArray[np.bool_]) -> NDArray[np.int32]:
    """Every configuration's component number ``[K, nx, ny]`` (0: not free), orientation
    wrapping round (``scipy.ndimage.label``, then the labels that meet across bins K-1 and 0
    joined)."""
    labels, count = ndimage.label(free, structure=NEIGHBOURS)
    both = free[0] & free[-1]
    ids = np.arange(count + 1)
    a = np.concatenate([ids, labels[0][both]])
    b = np.concatenate([ids, labels[-1][both]])
    graph = coo_matrix((np.ones(a.size), (a, b)), shape=(count + 1, count + 1))
    joined: NDArray[np.int32] = connected_components(graph, directed=False)[1].astype(np.int32)
    out: NDArray[np.int32] = np.where(free, joined[labels], 0).astype(np.int32)
    return out


class Feasibility:
    """Answers "can this body get from the start to that goal at all?" on one lethal layer."""

    def __init__(self, grid: LatticeGrid, table: MotionTable, clear: Array, margin: float) -> None:
        """``clear``: the lethal clearance at the cell centres ``[nx, ny]`` (or flat)."""
        self.grid, self.table, self.margin = grid, table, margin
        self.clear = np.ascontiguousarray(np.reshape(clear, (grid.nx, grid.ny)), dtype=float)
        self.rows = body_rows(grid, table, margin)
        self._labels: NDArray[np.int32] | None = None
        self.flood_budget = FLOOD_BUDGET

    def reaches(
        self, start: Key, goal: tuple[float, float], reach: float, compiled: bool | None = None
    ) -> bool:
        """``False`` only when no lattice plan can bring the head within ``reach`` of ``goal``
        from ``start`` (``True`` when one may, or when no configuration at the start passes
        the test: a robot touching something). ``compiled``: force the flood (True) or the
        labelling (False); by default the flood within its budget, then the labelling."""
        starts = self._starts(start)
        if starts.size == 0:
            return True
        limit = reach + self.grid.settings.resolution * math.sqrt(0.5)
        if compiled if compiled is not None else flood.AVAILABLE:
            found = self._flood(starts, goal, limit, self.flood_budget)
            if found is not None:
                return found
        return self._labelled_reaches(starts, goal, limit)

    def flood_decides(
        self, start: Key, goal: tuple[float, float], reach: float, budget: int
    ) -> bool | None:
        """``reaches`` by the flood alone within ``budget`` configurations: ``None`` when that
        leaves it undecided (or no compiled flood runs here). A cheap question to ask before a
        search: the flood decides a goal next door or one in a small pen at once, and spends
        its budget only where the two sides are large (a maze), where the search answers."""
        starts = self._starts(start)
        if starts.size == 0:
            return True
        if not flood.AVAILABLE:
            return None
        limit = reach + self.grid.settings.resolution * math.sqrt(0.5)
        return self._flood(starts, goal, limit, budget)

    def _flood(
        self, starts: NDArray[np.int64], goal: tuple[float, float], limit: float, budget: int
    ) -> bool | None:
        centres = self.grid.centres.reshape(self.grid.nx, self.grid.ny, 2)
        return flood.flood_reaches(
            self.clear,
            *self.rows,
            np.asarray(self.table.heads, dtype=float),
            np.ascontiguousarray(centres[:, 0, 0]),
            np.ascontiguousarray(centres[0, :, 1]),
            goal,
            limit,
            starts,
            budget,
        )

    def _labelled_reaches(
        self, starts: NDArray[np.int64], goal: tuple[float, float], limit: float
    ) -> bool:
        grid = self.grid
        if self._labels is None:
            free = free_configurations(grid, self.table, self.clear, self.rows)
            self._labels = components(free)
        labels = self._labels
        bins, cells = np.divmod(starts, grid.nx * grid.ny)
        mine = np.unique(labels[bins, *np.divmod(cells, grid.ny)])
        mine = mine[mine > 0]
        centres = grid.centres.reshape(grid.nx, grid.ny, 2)
        xs, ys = centres[:, 0, 0], centres[0, :, 1]
        for k, (hx, hy) in enumerate(self.table.heads):
            # Only the cells round the goal (less the head's offset) can hold the head on it.
            i0, i1 = np.searchsorted(xs, [goal[0] - hx - limit, goal[0] - hx + limit])
            j0, j1 = np.searchsorted(ys, [goal[1] - hy - limit, goal[1] - hy + limit])
            box = (slice(max(0, i0 - 1), i1 + 1), slice(max(0, j0 - 1), j1 + 1))
            near = np.hypot(centres[*box, 0] + hx - goal[0], centres[*box, 1] + hy - goal[1])
            if np.any(np.isin(labels[k][box][near <= limit], mine)):
                return True
        return False

    def _starts(self, start: Key) -> NDArray[np.int64]:
        """The free configurations at ``start`` or, when the snapped state itself fails the
        test (the robot stands closer to something than the margin), next to it: one cell and
        one orientation step around, where the real pose lies."""
        si, sj, sk = start
        grid = self.grid
        K, nx, ny = grid.settings.orientations, grid.nx, grid.ny
        found = []
        for dk in (0, -1, 1):
            for di in (0, -1, 1):
                for dj in (0, -1, 1):
                    k, i, j = (sk + dk) % K, si + di, sj + dj
                    if (
                        0 <= i < nx
                        and 0 <= j < ny
                        and flood.configuration_free(self.clear, *self.rows, k, i, j)
                    ):
                        found.append((k * nx + i) * ny + j)
            if found and dk == 0:
                break  # the start's own orientation decides when it can
        return np.asarray(found, dtype=np.int64)

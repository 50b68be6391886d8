"""Whether any body motion can bring the head to a goal: connectivity of the lattice's free
configuration space (cell, orientation), a cheap test that is sound for "unreachable".

The 2-D distance map treats the body as its centroid, so it misses places the body fits into
but cannot turn in (a dead-end lane entered tail first). Searching the lattice to exhaustion
would decide them but takes long; labelling the free configurations instead is one array
operation per body sample point and one ``scipy.ndimage.label``. The test relaxes the
lattice: a configuration is free when the resting body keeps its clearance (less the half cell
diagonal a point may sit off the cell centre it is rounded to), and neighbouring free
configurations (8 cells around at one orientation, or one orientation step in place) connect.
Every lattice motion joins configurations this relaxation also joins, so a goal outside the
start's component cannot be reached by any plan; the converse need not hold.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from domain.lattice import Key, LatticeGrid, MotionTable
from sim.robot import Array


def free_configurations(
    grid: LatticeGrid, table: MotionTable, at_centres: Array, margin: float
) -> NDArray[np.bool_]:
    """``[K, nx, ny]``: where the resting body may lie (relaxed by half a cell diagonal), from
    the clearance at ``grid.centres``."""
    nx, ny, r = grid.nx, grid.ny, grid.settings.resolution
    clear = at_centres.reshape(nx, ny)
    # Padded with -inf: a body point off the grid is outside the arena.
    pad = max(1, math.ceil(table.geometry.body_length / r) + 2)
    padded = np.full((nx + 2 * pad, ny + 2 * pad), -np.inf)
    padded[pad : pad + nx, pad : pad + ny] = clear
    slack = r * math.sqrt(0.5)
    K = grid.settings.orientations
    free = np.ones((K, nx, ny), dtype=bool)
    for k in range(K):
        shifts = np.rint(table.body_points[k] / r).astype(np.int64)
        # One comparison per distinct cell shift, against the largest need rounded into it.
        unique, inverse = np.unique(shifts, axis=0, return_inverse=True)
        needs = np.full(len(unique), -np.inf)
        np.maximum.at(needs, inverse.ravel(), table.body_needs[k])
        for (di, dj), need in zip(unique, needs, strict=True):
            if abs(di) >= pad or abs(dj) >= pad:
                free[k] = False
                break
            window = padded[pad + di : pad + di + nx, pad + dj : pad + dj + ny]
            free[k] &= window >= need + margin - slack
    return free


class Reachability:
    """The components of one lattice's free configurations, asked for many starts and goals."""

    def __init__(
        self, grid: LatticeGrid, table: MotionTable, at_centres: Array, margin: float
    ) -> None:
        self.grid, self.table = grid, table
        self.free = free_configurations(grid, table, at_centres, margin)
        structure = np.zeros((3, 3, 3), dtype=bool)
        structure[1] = True  # the 8 neighbouring cells at one orientation ...
        structure[0, 1, 1] = structure[2, 1, 1] = True  # ... and one orientation step in place
        self.labels, count = ndimage.label(self.free, structure=structure)
        # Orientation wraps round: join the components that meet across bins K-1 and 0.
        both = self.free[0] & self.free[-1]
        a, b = self.labels[0][both], self.labels[-1][both]
        ids = np.arange(count + 1)
        joined = coo_matrix(
            (np.ones(a.size + ids.size), (np.r_[a, ids], np.r_[b, ids])),
            shape=(count + 1, count + 1),
        )
        self.component = connected_components(joined, directed=False)[1]

    def reaches(self, start: Key, goal: tuple[float, float], reach: float) -> bool:
        """``False`` only when no lattice plan can bring the head within ``reach`` of ``goal``
        from ``start`` (``True`` when one may, or when no configuration at the start passes
        the test: a robot touching something)."""
        mine = self._components_at(start)
        if mine.size == 0:
            return True
        grid = self.grid
        centres = grid.centres.reshape(grid.nx, grid.ny, 2)
        slack = grid.settings.resolution * math.sqrt(0.5)
        for k, (hx, hy) in enumerate(self.table.heads):
            near = np.hypot(centres[..., 0] + hx - goal[0], centres[..., 1] + hy - goal[1])
            mask = (near <= reach + slack) & self.free[k]
            if np.any(np.isin(self.component[self.labels[k][mask]], mine)):
                return True
        return False

    def _components_at(self, start: Key) -> NDArray[np.intp]:
        """The components of the free configurations at ``start`` or, when the snapped state
        itself fails the test (the robot stands closer to something than the margin), next to
        it: one cell and one orientation step around, where the real pose lies."""
        si, sj, sk = start
        K, nx, ny = self.free.shape
        found = []
        for dk in (0, -1, 1):
            for di in (0, -1, 1):
                for dj in (0, -1, 1):
                    k, i, j = (sk + dk) % K, si + di, sj + dj
                    if 0 <= i < nx and 0 <= j < ny and self.free[k, i, j]:
                        found.append(self.component[self.labels[k, i, j]])
            if found and dk == 0:
                break  # the start's own orientation decides when it can
        return np.unique(np.asarray(found, dtype=np.intp))

"""Clearance to one layer's occupied cells, kept current without re-running the whole transform.

The clearance of a cell to a layer is the distance between its centre and the nearest occupied
cell's, minus half a cell, clipped to ``[0, cap]`` (a Euclidean distance transform, scipy's
``ndimage``). A tick of sensing adds a few occupied cells; their effect reaches no further than
``cap`` plus half a cell, so ``DistanceMap.add`` transforms only a window around them and takes
the minimum with what it had. That equals a full transform value for value: the transform's
distances are exact, the clipped map is a non-decreasing function of them, and the distance to a
union of cells is the minimum of the distances to each part. Cells that stop being occupied need
the full transform again (``DistanceMap.reset``); they are rare (noise decaying).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from domain.grid import Flat, Grid
from sim.robot import Array


def clearance_map(occupied: NDArray[np.bool_], resolution: float, cap: float) -> Array:
    """Clearance ``[nx, ny]`` of every cell centre to the occupied cells (``cap`` if none)."""
    if not np.any(occupied):
        return np.full(occupied.shape, cap)
    dist = ndimage.distance_transform_edt(~occupied) * resolution - 0.5 * resolution
    out: Array = np.clip(dist, 0.0, cap)
    return out


class DistanceMap:
    """The clearance map of one occupancy layer, updated as cells are added or removed."""

    def __init__(self, grid: Grid, cap: float) -> None:
        self.grid = grid
        self.cap = cap
        self._map: Array | None = None  # None: recompute from the layer on the next read
        # cells within this many of an added cell may get closer to something
        self._reach = math.ceil((cap + 0.5 * grid.resolution) / grid.resolution) + 1

    def reset(self) -> None:
        """Forget the map: the layer changed in a way a window cannot follow (cells removed)."""
        self._map = None

    def add(self, occupied: NDArray[np.bool_], cells: Flat) -> None:
        """Cells ``cells`` (flat indices) became occupied in ``occupied`` (the layer, after)."""
        if self._map is None or cells.size == 0:
            return
        i, j = np.divmod(cells, self.grid.ny)
        r = self._reach
        i0, i1 = max(int(i.min()) - r, 0), min(int(i.max()) + r + 1, self.grid.nx)
        j0, j1 = max(int(j.min()) - r, 0), min(int(j.max()) + r + 1, self.grid.ny)
        added = np.zeros((i1 - i0, j1 - j0), dtype=bool)
        added[i - i0, j - j0] = True
        near = clearance_map(added, self.grid.resolution, self.cap)
        updated = self._map.copy()  # the old map may be shared with callers: never edit it
        np.minimum(updated[i0:i1, j0:j1], near, out=updated[i0:i1, j0:j1])
        self._map = updated

    def get(self, occupied: NDArray[np.bool_]) -> Array:
        """The clearance map of ``occupied`` (the layer as it is now)."""
        if self._map is None:
            self._map = clearance_map(occupied, self.grid.resolution, self.cap)
        return self._map

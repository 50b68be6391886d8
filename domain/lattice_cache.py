"""Which motions are free from which lattice state, kept between replans and repaired locally.

A replan after a local change (an obstacle sensed, a contact) searches mostly the states the
last search saw, and their motions' swept footprints are still free unless the change lies
near them. The cache samples the clearance at every cell centre, capped at what any motion
needs (changes beyond that cannot change a verdict), and drops only the states within a
motion's reach of a cell whose capped clearance changed.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from domain.lattice import LatticeGrid, MotionTable
from sim.robot import Array


class MotionCache:
    """Free motions per lattice state number for one shape and margin."""

    def __init__(self, grid: LatticeGrid, table: MotionTable, margin: float) -> None:
        self.grid, self.table, self.margin = grid, table, margin
        self.free: dict[int, NDArray[np.bool_]] = {}
        # Clearance above this decides nothing: every motion needs less at every point.
        self.cap = max(float(np.max(n)) for n in table.needs) + margin + grid.settings.resolution
        # A motion's points lie within this of its start centroid (plus bilinear support).
        self.reach = max(float(np.max(np.linalg.norm(p, axis=-1))) for p in table.points)
        self._capped: Array | None = None
        self.version: object = None

    def refresh(self, at_centres: Array, version: object) -> None:
        """Forget the states near any cell whose (capped) clearance changed since the last
        world ``version`` seen (``at_centres``: the clearance at the grid's cell centres)."""
        if version == self.version:
            return
        self.version = version
        capped = np.minimum(at_centres.reshape(self.grid.nx, self.grid.ny), self.cap)
        old, self._capped = self._capped, capped
        if old is None or not self.free:
            self.free.clear()
            return
        changed = np.abs(capped - old) > 1e-9
        if not np.any(changed):
            return
        r = self.grid.settings.resolution
        near = ndimage.distance_transform_edt(~changed) * r <= self.reach + 2 * r * math.sqrt(2)
        ny, plane = self.grid.ny, self.grid.nx * self.grid.ny
        for number in list(self.free):
            i, j = divmod(number % plane, ny)
            if near[i, j]:
                del self.free[number]

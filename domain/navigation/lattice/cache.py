"""What the motions of the lattice states a search met cost, kept between replans.

A replan after a local change (an obstacle sensed, a contact, cells observed) searches mostly
the states the last search saw, and most of what their motions cost still holds unless the
change lies near them. The cache keeps it in two parts: what the lethal layer decides (valid
motions as a bitmask, their length and closeness costs), which changes seldom, and what the
soft layers risk, which changes near the robot at every tick as it observes; each part drops
only the states within a motion's reach of a cell whose lethal clearance (capped at what any
motion needs or prices) or whose risk changed.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from domain.navigation.lattice.grid import LatticeGrid
from domain.navigation.lattice.motions import MotionTable
from domain.navigation.lattice.store import Store
from sim.robot import Array

ROWS_LIMIT = 1_000_000  # states whose rows are kept (~200 B each); then a part starts afresh
# (what it forgets is evaluated again when met: no plan changes)
FIRST_ROWS = 65536


class Rows:
    """State number -> a row of ``ints`` (one) and ``floats`` (``width``), grown on demand."""

    def __init__(self, width: int, limit: int = ROWS_LIMIT) -> None:
        self.index = Store(2 * FIRST_ROWS)
        # (rows are written whole before they are read: ``used`` counts those handed out)
        self.ints = np.empty(FIRST_ROWS, dtype=np.int64)
        self.floats = np.empty((FIRST_ROWS, max(1, width)))
        self.used = np.zeros(1, dtype=np.int64)  # rows handed out
        self.limit = limit

    def __len__(self) -> int:
        return len(self.index)

    def clear(self) -> None:
        self.index = Store()
        self.used[0] = 0

    def room(self, more: int) -> None:
        """Room for ``more`` new rows and their keys (grown, or started afresh past the limit)."""
        if int(self.used[0]) + more > self.limit:
            self.clear()
        self.index.room(more)
        while int(self.used[0]) + more > len(self.ints):
            grow = len(self.ints)
            self.ints = np.concatenate([self.ints, np.empty(grow, dtype=np.int64)])
            self.floats = np.concatenate([self.floats, np.empty((grow, self.floats.shape[1]))])

    def forget(self, changed: NDArray[np.bool_], grid: LatticeGrid, reach: float) -> None:
        """Drop the states within ``reach`` metres of a changed cell (``changed``: the grid)."""
        if not len(self.index) or not changed.any():
            return
        rows, cols = np.flatnonzero(changed.any(axis=1)), np.flatnonzero(changed.any(axis=0))
        box = changed[rows[0] : rows[-1] + 1, cols[0] : cols[-1] + 1]
        r = grid.settings.resolution
        limit = reach + 2 * r * math.sqrt(2)
        pad = math.ceil(limit / r)
        grown = np.pad(box, pad)  # states just outside the box may reach into it
        near = ndimage.distance_transform_edt(~grown) * r <= limit
        plane, ny = grid.nx * grid.ny, grid.ny
        self.index.forget_near(near, int(rows[0]) - pad, int(cols[0]) - pad, plane, ny)


class MotionCache:
    """The lethal and the risk parts of evaluated states, for one body and margin."""

    def __init__(
        self, grid: LatticeGrid, table: MotionTable, cap: float, rows_limit: int | None = None
    ) -> None:
        # None: the module's limit as it is when the cache is made (a service process may
        # size it to the memory it may use).
        rows_limit = ROWS_LIMIT if rows_limit is None else rows_limit
        if rows_limit < 1:
            raise ValueError("rows_limit: at least 1 state")
        self.grid, self.table = grid, table
        # Clearance above this decides nothing: every motion needs and prices less.
        self.cap = cap
        n_motions = len(table.motions)
        self.lethal = Rows(n_motions, rows_limit)  # bits, base costs
        self.risk = Rows(n_motions, rows_limit)  # (unused), risk costs
        self._capped: Array | None = None
        self._risk: Array | None = None
        self._blocked: Array | None = None
        self.version: object = None

    def refresh(self, lethal: Array, risk: Array, blocked: Array, version: object) -> None:
        """Forget the states near any cell whose (capped) lethal clearance, or whose risk,
        changed since the last world ``version`` seen (each ``[nx, ny]``, the costmap's cells)."""
        if version == self.version:
            return
        self.version = version
        capped = np.minimum(lethal, self.cap)
        if self._capped is None:
            self.lethal.clear()
        else:
            self.lethal.forget(np.abs(capped - self._capped) > 1e-12, self.grid, self.table.reach)
        if self._risk is None or self._blocked is None:
            self.risk.clear()
        else:
            changed = (risk != self._risk) | (blocked != self._blocked)
            reach = self.table.cell_reach_new * self.grid.settings.resolution
            self.risk.forget(changed, self.grid, reach)
        self._capped = capped
        self._risk, self._blocked = np.array(risk, copy=True), np.array(blocked, copy=True)

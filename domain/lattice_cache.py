"""Which motions are free from which lattice state, kept between replans and repaired locally.

A replan after a local change (an obstacle sensed, a contact) searches mostly the states the
last search saw, and their motions' swept footprints are still free unless the change lies
near them. The cache samples the clearance at every cell centre, capped at what any motion
needs (changes beyond that cannot change a verdict), and drops only the states within a
motion's reach of a cell whose capped clearance changed.
"""

from __future__ import annotations

import math
from itertools import islice

import numpy as np
from numpy.typing import NDArray
from pyperplan.task import Operator
from scipy import ndimage

from domain.lattice import LatticeGrid, MotionTable
from domain.lattice_states import LatticeState, StatePool
from domain.lattice_store import Store
from sim.robot import Array

MOVES_LIMIT = 10_000  # states whose successors are kept (~5-10 KB each); then the older half goes
COMPILED_LIMIT = 1_000_000  # states whose free motions the compiled store keeps (~32-64 B each);
# then it starts afresh (what it forgets is checked again when met: no plan changes)
Moves = tuple[list[tuple[Operator, LatticeState]], list[tuple[int, str]]]  # successors, edges


class MotionCache:
    """Free motions per lattice state number for one shape and margin."""

    def __init__(
        self,
        grid: LatticeGrid,
        table: MotionTable,
        margin: float,
        states: StatePool | None = None,
        moves_limit: int = MOVES_LIMIT,
        compiled_limit: int = COMPILED_LIMIT,
    ) -> None:
        if moves_limit < 1:
            raise ValueError("moves_limit: at least 1 state")
        if compiled_limit < 1:
            raise ValueError("compiled_limit: at least 1 state")
        self.compiled_limit = compiled_limit
        self.grid, self.table, self.margin = grid, table, margin
        self.free: dict[int, NDArray[np.bool_]] = {}
        # Successors of the states in ``free`` (from the same verdicts), built on demand.
        self.moves: dict[int, Moves] = {}
        # The same verdicts for the compiled search (domain/lattice_search.py): state number ->
        # free motions as a bitmask, in a numba typed dict (made on first use).
        self._compiled: Store | None = None
        self.moves_limit = moves_limit
        self.states = states if states is not None else StatePool()
        # Clearance above this decides nothing: every motion needs less at every point.
        self.cap = table.largest_need + margin + grid.settings.resolution
        # A motion's points lie within this of its start centroid (plus bilinear support).
        self.reach = table.reach
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
        if old is None or not (self.free or self._compiled is not None):
            self.free.clear()
            self.moves.clear()
            self._compiled = None
            return
        changed = np.abs(capped - old) > 1e-9
        if np.any(changed):
            self._forget(changed, (0, 0))

    def refresh_window(self, at_cells: Array, window: tuple[slice, slice]) -> None:
        """Refresh from the clearance in ``window`` alone (``at_cells``: at its cell centres),
        for a search among states at least a motion's reach inside it: every change that
        could touch their motions lies in it. Changes outside are left for the next full
        ``refresh`` (the cache no longer claims a world version, so it compares everything)."""
        if self._capped is None:
            # No clearance seen yet (a cache first used by a repair): what it holds was
            # checked against nothing it can compare, and everything outside the window is
            # unknown, so compares as changed at the next full refresh.
            self.free.clear()
            self.moves.clear()
            self._compiled = None
            self._capped = np.full((self.grid.nx, self.grid.ny), np.inf)
        wi, wj = window
        capped = np.minimum(at_cells.reshape(wi.stop - wi.start, wj.stop - wj.start), self.cap)
        changed = np.abs(capped - self._capped[wi, wj]) > 1e-9
        self._capped[wi, wj] = capped
        self.version = None
        if np.any(changed):
            self._forget(changed, (wi.start, wj.start))

    def _forget(self, changed: NDArray[np.bool_], origin: tuple[int, int]) -> None:
        """Drop the states within a motion's reach of a changed cell (``changed``: a window of
        cells whose first cell is ``origin``)."""
        if not (self.free or self._compiled is not None):
            return
        # Only the changed cells' bounding box matters (the distances below reach past it).
        rows, cols = np.flatnonzero(changed.any(axis=1)), np.flatnonzero(changed.any(axis=0))
        if rows.size == 0:
            return
        changed = changed[rows[0] : rows[-1] + 1, cols[0] : cols[-1] + 1]
        origin = (origin[0] + int(rows[0]), origin[1] + int(cols[0]))
        r = self.grid.settings.resolution
        limit = self.reach + 2 * r * math.sqrt(2)
        pad = math.ceil(limit / r)
        grown = np.pad(changed, pad)  # states just outside the window may reach into it
        near = ndimage.distance_transform_edt(~grown) * r <= limit

        plane, ny = self.grid.nx * self.grid.ny, self.grid.ny
        if self.free:
            numbers = np.fromiter(self.free, dtype=np.int64, count=len(self.free))
            i, j = np.divmod(numbers % plane, ny)
            li, lj = i - origin[0] + pad, j - origin[1] + pad
            inside = (li >= 0) & (li < near.shape[0]) & (lj >= 0) & (lj < near.shape[1])
            hit = np.zeros(numbers.size, dtype=bool)
            hit[inside] = near[li[inside], lj[inside]]
            moves = self.moves
            for number in numbers[hit].tolist():
                del self.free[number]
                moves.pop(number, None)
        if self._compiled is not None:  # the same states, in the compiled store
            self._compiled.forget_near(near, origin[0] - pad, origin[1] - pad, plane, ny)

    def compiled_free(self) -> Store:
        """The free motions for the compiled search: state number -> bitmask (bit ``m``:
        motion ``m``), kept and forgotten as ``free`` is."""
        if self._compiled is None or len(self._compiled) >= self.compiled_limit:
            self._compiled = Store()
        return self._compiled

    def keep_moves(self, number: int, moves: Moves) -> None:
        """Keep the successors built for a state whose free motions this cache holds."""
        if len(self.moves) >= self.moves_limit:  # the older half goes (built again if needed)
            for old in list(islice(self.moves, max(1, len(self.moves) // 2))):
                del self.moves[old]
        self.moves[number] = moves

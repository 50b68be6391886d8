"""The cells the suspected tier keeps clear of, and their clearance, kept current window by window.

With ``suspected``, ``WorldModel.inflated_clearance_at`` counts as contact cells the *marked*
cells: contacts, suspected surfaces (where a touched one probably goes on: flagged by
``suspect``, cleared by beams that see them free) and the sensed layer's continuation,
never-observed cells (log-odds 0) within ``sensed_continuation`` of a sensed cell. They
change with nearly every version of the model, but a few cells at a time, so
``MarkedCells`` marks afresh only the windows where what a cell's status depends on changed
since it last did, and hands the cells whose status changed to a ``DistanceMap``
(``domain.clearance``), which updates the clearance around them. Where a status may change:

- its contact or suspected flag: the cells flagged or cleared (``flagged``);
- its log-odds being 0: the cells a reading touched (``touched``);
- its clearance to the sensed cells being within the reach: only within the reach plus half a
  cell of a sensed cell that came or went (``sensed_changed``): the distance to the nearest
  sensed cell changes only where that cell is one of them. When the sensed layer empties or
  stops being empty, everywhere (with no sensed cell there is no continuation).

The status is taken when the model asks (``sync``, once per version of the model): as the
full layer ``contact | suspected | continuation`` would be built then.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from domain import occupancy_kernel
from domain.clearance import DistanceMap, Window, overlap, union
from domain.grid import Flat, Grid, unique_cells
from sim.robot import Array

MAX_DIRTY_WINDOWS = 32  # windows kept apart before they are merged into one
MAX_PENDING = 64  # changed cells' arrays kept before their window is taken


class MarkedCells:
    """Contacts, suspected surfaces and the sensed layer's continuation, as one layer with its
    clearance map; brought up to date by ``sync``."""

    def __init__(self, grid: Grid, continuation: float, cap: float) -> None:
        self.grid = grid
        self.continuation = continuation
        # Where a touched surface probably goes on (a bumper feels a short piece of a wall);
        # avoided while a way round exists, cleared by beams that see the cells free.
        self.suspected = np.zeros(grid.shape, dtype=bool)
        self.suspected_count = 0  # suspected cells (none: no scan, no suspect tier)
        # cells suspected since the last reading: they may have been seen free before
        self._newly_suspected: list[Flat] = []
        self.marked = np.zeros(grid.shape, dtype=bool)  # as of the last sync
        self.count = 0  # marked cells
        self.map = DistanceMap(grid, cap)  # clearance to the marked cells
        # cells within this many of a sensed cell that came or went may cross the reach: the
        # reach plus half a cell, in cells (rounded up: a cell more than the floor needs, for
        # the rounding of the clearance; ``tests/domain/test_marked.py`` fails on two fewer)
        self.grow = math.ceil((continuation + 0.5 * grid.resolution) / grid.resolution)
        self._dirty: list[Window] = []
        # changed cells (flat) not yet turned into windows: each reading's, and the sensed
        # cells that came or went (a window is taken when the model asks, not per reading)
        self._pending: list[Flat] = []
        self._pending_sensed: list[Flat] = []
        self._reach = -1.0  # the reach used at the last sync (-1: no continuation)

    def suspect(self, cells: Flat, contact: NDArray[np.bool_]) -> bool:
        """Flag ``cells`` (flat, distinct) as a suspected surface, but for contact cells and
        those flagged already; whether any was new."""
        flat = self.suspected.reshape(-1)
        cells = cells[~contact.reshape(-1)[cells] & ~flat[cells]]
        if not cells.size:
            return False
        flat[cells] = True
        self.suspected_count += int(cells.size)
        self._newly_suspected.append(cells)
        self.flagged(cells)
        return True

    def seen_free(self, lowered: Flat, log_odds: Array, cleared_at: float) -> bool:
        """After a reading that lowered the log-odds of ``lowered``: suspected cells whose
        log-odds are at most ``cleared_at`` are seen free and cleared; whether any was."""
        newly, self._newly_suspected = self._newly_suspected, []
        if not self.suspected_count:
            return False
        # only cells this reading lowered, or suspected since the last one, can have got there
        cells = np.concatenate([lowered, *newly]) if newly else lowered
        flat = self.suspected.reshape(-1)
        cells = cells[flat[cells]]
        free = cells[log_odds.reshape(-1)[cells] <= cleared_at]
        if not free.size:  # as a rule: then no sorting
            return False
        free = unique_cells(free)
        flat[free] = False
        self.suspected_count -= int(free.size)
        self.flagged(free)
        return True

    def touched(self, cells: Sequence[Flat]) -> None:
        """A reading may have changed the log-odds of ``cells`` (flat, in parts)."""
        self._pending.extend(cells)
        if len(self._pending) > MAX_PENDING:
            self._take(self._pending, 0)

    def flagged(self, cells: Flat) -> None:
        """The contact or suspected flag of ``cells`` (flat) changed."""
        self.touched((cells,))

    def sensed_changed(self, cells: Sequence[Flat]) -> None:
        """``cells`` (flat, in parts) became sensed or stopped being so."""
        if self.continuation > 0:
            self._pending_sensed.extend(cells)
            if len(self._pending_sensed) > MAX_PENDING:
                self._take(self._pending_sensed, self.grow)

    def sync(
        self,
        contact: NDArray[np.bool_],
        sensed_clearance: Array,
        log_odds: Array,
        any_sensed: bool,
    ) -> list[Window]:
        """Mark afresh where the layers changed since the last sync (``sensed_clearance``: the
        clearance to the sensed cells now); returns the windows where the clearance map may
        have changed."""
        self._take(self._pending, 0)
        self._take(self._pending_sensed, self.grow)
        reach = self.continuation if self.continuation > 0 and any_sensed else -1.0
        if reach != self._reach:  # the continuation appears or goes everywhere at once
            self._reach = reach
            self._dirty = [(0, self.grid.nx, 0, self.grid.ny)]
        if not self._dirty:
            return []
        added, removed = [], []
        for window in self._dirty:
            flags = (contact, self.suspected, sensed_clearance, log_odds)
            on, off = mark(*flags, reach, window, self.marked)
            added.append(on)
            removed.append(off)
        self._dirty = []
        became, ceased = np.concatenate(added), np.concatenate(removed)
        self.count += int(became.size) - int(ceased.size)
        # removed first (their window measured afresh, the new cells included), then added
        windows = [self.map.remove((self.marked,), ceased), self.map.add(self.marked, became)]
        return [w for w in windows if w is not None]

    def clearance(self) -> Array:
        """The clearance map of the marked cells as of the last sync (read it there and then)."""
        return self.map.get(self.marked)

    def _take(self, pending: list[Flat], grow: int) -> None:
        """The status of cells within ``grow`` of the ``pending`` cells may have changed:
        their window is dirty (``pending`` emptied)."""
        cells = np.concatenate(pending) if pending else None
        pending.clear()
        if cells is None or cells.size == 0:
            return
        window = self.map.window(cells, grow)
        dirty = self._dirty
        if dirty and overlap(dirty[-1], window):
            dirty[-1] = union(dirty[-1], window)
        elif len(dirty) >= MAX_DIRTY_WINDOWS:
            merged = window
            for other in dirty:
                merged = union(merged, other)
            self._dirty = [merged]
        else:
            dirty.append(window)


def mark(
    contact: NDArray[np.bool_],
    suspected: NDArray[np.bool_],
    sensed_clearance: Array,
    log_odds: Array,
    reach: float,
    window: Window,
    marked: NDArray[np.bool_],
) -> tuple[Flat, Flat]:
    """``marked`` over ``window`` becomes ``contact | suspected | (sensed_clearance <= reach &
    log_odds == 0)``; returns the cells (flat) that became marked and those that ceased."""
    if occupancy_kernel.AVAILABLE:
        on, off = _mark_window(
            contact, suspected, sensed_clearance, log_odds, reach, window, marked
        )
        return on, off
    i0, i1, j0, j1 = window
    now = contact[i0:i1, j0:j1] | suspected[i0:i1, j0:j1]
    now |= (sensed_clearance[i0:i1, j0:j1] <= reach) & (log_odds[i0:i1, j0:j1] == 0.0)
    before = marked[i0:i1, j0:j1]
    ii, jj = np.nonzero(now != before)
    flat = (ii + i0) * marked.shape[1] + (jj + j0)
    became = now[ii, jj]
    marked[i0:i1, j0:j1] = now
    return flat[became], flat[~became]


@occupancy_kernel._jit
def _mark_window(  # pragma: no cover - compiled
    contact: NDArray[np.bool_],
    suspected: NDArray[np.bool_],
    sensed_clearance: Array,
    log_odds: Array,
    reach: float,
    window: Window,
    marked: NDArray[np.bool_],
) -> tuple[Flat, Flat]:
    """``mark``'s numpy formula, cell by cell, the cells in the same (row-major) order."""
    i0, i1, j0, j1 = window
    ny = marked.shape[1]
    on = np.empty((i1 - i0) * (j1 - j0), dtype=np.int64)
    off = np.empty((i1 - i0) * (j1 - j0), dtype=np.int64)
    n_on = 0
    n_off = 0
    for i in range(i0, i1):
        for j in range(j0, j1):
            now = contact[i, j] or suspected[i, j]
            if not now and sensed_clearance[i, j] <= reach and log_odds[i, j] == 0.0:
                now = True
            if now != marked[i, j]:
                marked[i, j] = now
                if now:
                    on[n_on] = i * ny + j
                    n_on += 1
                else:
                    off[n_off] = i * ny + j
                    n_off += 1
    return on[:n_on], off[:n_off]

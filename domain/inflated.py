"""The world model's inflated clearance grids, kept current window by window as its layers change.

``WorldModel.inflated_clearance_at`` reads one grid per (sensed inflation, contact inflation,
suspected tier): the sensed cells' clearance less one inflation, the contacts' (with the
suspected tier: the marked cells', ``domain.marked``) less the other, at least 0, at most the
static layer's. The formula is element by element, so a window of it equals the same window of
the whole: each grid keeps the windows where its inputs changed since it was last read and
recomputes only those when next read (rebuilt when too many have piled up).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from domain import occupancy_kernel
from domain.clearance import Window, overlap, union
from domain.grid import Grid
from sim.robot import Array

MAX_STALE_WINDOWS = 64  # windows a grid is brought up to date by, before a rebuild

Key = tuple[float, float, bool]  # sensed inflation, contact inflation, suspected tier


@dataclass
class _Inflated:
    """One grid and the windows changed since it was last brought up to date."""

    values: Array
    stale: list[Window] = field(default_factory=list)


class InflatedGrids:
    """The inflated clearance grids, one per key, private to their world model."""

    def __init__(self, grid: Grid) -> None:
        self.grid = grid
        self._grids: dict[Key, _Inflated] = {}

    def reset(self) -> None:
        """Forget every grid (an input changed everywhere): each is rebuilt when next read."""
        self._grids.clear()

    def changed(self, window: Window | None, suspected_only: bool = False) -> None:
        """An input changed within ``window`` (``None``: nowhere), for every grid or only the
        suspected tier's (its marked cells): those grids are brought up to date there when
        next read, or rebuilt when too much has changed."""
        if window is None:
            return
        for key in list(self._grids):
            if suspected_only and not key[2]:
                continue
            stale = self._grids[key].stale
            if len(stale) >= MAX_STALE_WINDOWS:
                del self._grids[key]
            elif stale and overlap(stale[-1], window):
                stale[-1] = union(stale[-1], window)  # one update of both (nearby changes)
            else:
                stale.append(window)

    def get(self, key: Key, static: Array, sensed: Array, near: Array) -> Array:
        """The grid of ``key`` from the static layer's, the sensed cells' and the contacts' (or
        marked cells') clearance as they are now, brought up to date where they changed since
        it was last read (the grid itself: read it, do not keep or change it)."""
        inflation, grow, _ = key
        entry = self._grids.get(key)
        if entry is None:
            entry = self._grids[key] = _Inflated(np.empty(self.grid.shape))
            inflate(
                static,
                sensed,
                near,
                inflation,
                grow,
                (0, self.grid.nx, 0, self.grid.ny),
                entry.values,
            )
        else:
            for window in entry.stale:
                inflate(static, sensed, near, inflation, grow, window, entry.values)
            entry.stale = []
        return entry.values


def inflate(
    static: Array,
    sensed: Array,
    near: Array,
    inflation: float,
    grow: float,
    window: Window,
    out: Array,
) -> None:
    """The inflated grid over ``window`` of ``out``: ``sensed`` (the sensed cells' clearance)
    less ``inflation``, ``near`` (the contacts', or the marked cells') less ``grow``, at least 0,
    at most ``static``. Element by element, so a window of it equals the same window of the
    whole; the smaller of two clearances less one inflation is the smaller clearance less it,
    so one formula serves equal inflations too."""
    if occupancy_kernel.AVAILABLE:
        _inflate_window(static, sensed, near, inflation, grow, window, out)
        return
    i0, i1, j0, j1 = window
    grown = np.minimum(
        np.maximum(sensed[i0:i1, j0:j1] - inflation, 0.0),
        np.maximum(near[i0:i1, j0:j1] - grow, 0.0),
    )
    out[i0:i1, j0:j1] = np.minimum(static[i0:i1, j0:j1], grown)


@occupancy_kernel._jit
def _inflate_window(  # pragma: no cover - compiled
    static: Array,
    sensed: Array,
    near: Array,
    inflation: float,
    grow: float,
    window: Window,
    out: Array,
) -> None:
    """``inflate``'s numpy formula, cell by cell over ``window`` of ``out``."""
    for i in range(window[0], window[1]):
        for j in range(window[2], window[3]):
            a = max(sensed[i, j] - inflation, 0.0)
            b = max(near[i, j] - grow, 0.0)
            out[i, j] = min(static[i, j], min(a, b))

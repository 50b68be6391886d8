"""Clearance to one layer's occupied cells, kept current without re-running the whole transform.

The clearance of a cell to a layer is the distance between its centre and the nearest occupied
cell's, minus half a cell, clipped to ``[0, cap]`` (an exact Euclidean distance transform:
compiled, or scipy's ``ndimage`` without numba, the same numbers). A tick of sensing adds or removes a few occupied cells; their effect reaches no
further than ``cap`` plus half a cell, so ``DistanceMap`` updates only a window around them:

- **added** cells: the transform of the added cells alone over the window, and the minimum with
  what the map had. That equals a full transform value for value: the transform's distances are
  exact, the clipped map is a non-decreasing function of them, and the distance to a union of
  cells is the minimum of the distances to each part.
- **removed** cells: the cells within reach of them get the transform of the layer over that
  window grown by the reach once more (every occupied cell that can be nearest to one of them
  lies inside it; one further away is beyond ``cap`` either way, where the map saturates).
  Compiled, a few removed cells are cheaper still: only a cell whose clearance equals that to a
  removed cell can have lost its nearest one (``_lost``); only those are measured again, to the
  occupied cells left within reach (``_remeasure``), or, when that would take longer, by the
  transform over their own window grown by the reach.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from domain import kernels as occupancy_kernel
from domain.world.grid import Flat, Grid
from sim.robot import Array

Window = tuple[int, int, int, int]  # cells i0:i1, j0:j1


def overlap(a: Window, b: Window) -> bool:
    """Whether two windows share cells."""
    return a[0] < b[1] and b[0] < a[1] and a[2] < b[3] and b[2] < a[3]


def union(a: Window, b: Window) -> Window:
    """The smallest window holding both."""
    return min(a[0], b[0]), max(a[1], b[1]), min(a[2], b[2]), max(a[3], b[3])


def clearance_map(occupied: NDArray[np.bool_], resolution: float, cap: float) -> Array:
    """Clearance ``[nx, ny]`` of every cell centre to the occupied cells (``cap`` if none).

    Compiled (``_compiled_map``) when numba is there, else scipy's transform: the same
    numbers either way."""
    if not np.any(occupied):
        return np.full(occupied.shape, cap)
    if occupancy_kernel.AVAILABLE:
        out = np.empty(occupied.shape)
        _compiled_map(np.ascontiguousarray(occupied), resolution, cap, out)
        return out
    dist = ndimage.distance_transform_edt(~occupied) * resolution - 0.5 * resolution
    clipped: Array = np.clip(dist, 0.0, cap)
    return clipped


@occupancy_kernel.jit
def _compiled_map(  # pragma: no cover - compiled
    occupied: NDArray[np.bool_], resolution: float, cap: float, out: Array
) -> None:
    """``clearance_map`` into ``out``: the exact squared distance (in cells) of every cell to
    the nearest occupied one by Meijster, Roerdink and Hesselink's two passes (integers
    throughout), then as scipy's transform turns it into metres: the square root of the
    squared distance as a float, times ``resolution``, less half a cell, clipped."""
    nx, ny = occupied.shape
    far = nx + ny  # further than any cell: "nothing in this column"
    g = np.empty((nx, ny), dtype=np.int64)
    # down each column (row by row, for memory order): the distance to the nearest occupied
    # cell of the column above, then below
    for j in range(ny):
        g[0, j] = 0 if occupied[0, j] else far
    for i in range(1, nx):
        for j in range(ny):
            g[i, j] = 0 if occupied[i, j] else min(g[i - 1, j] + 1, far)
    for i in range(nx - 2, -1, -1):
        for j in range(ny):
            if g[i + 1, j] < g[i, j]:
                g[i, j] = g[i + 1, j] + 1
    s = np.empty(ny, dtype=np.int64)
    t = np.empty(ny, dtype=np.int64)
    g2 = np.empty(ny, dtype=np.int64)
    half = 0.5 * resolution
    for i in range(nx):  # along each row: the lower envelope of the columns' parabolas
        for u in range(ny):
            g2[u] = g[i, u] * g[i, u]
        q = 0
        s[0] = 0
        t[0] = 0
        for u in range(1, ny):
            while q >= 0:
                a, x = s[q], t[q]
                if (x - a) * (x - a) + g2[a] <= (x - u) * (x - u) + g2[u]:
                    break
                q -= 1
            if q < 0:
                q = 0
                s[0] = u
            else:
                a = s[q]
                w = 1 + (u * u - a * a + g2[u] - g2[a]) // (2 * (u - a))
                if w < ny:
                    q += 1
                    s[q] = u
                    t[q] = w
        for u in range(ny - 1, -1, -1):
            a = s[q]
            d2 = (u - a) * (u - a) + g2[a]
            dist = math.sqrt(float(d2)) * resolution - half
            out[i, u] = min(max(dist, 0.0), cap)
            if u == t[q]:
                q -= 1


FEW_CELLS = 8  # added cells measured one by one (beyond: a transform of their window)


@occupancy_kernel.jit
def _add_few(  # pragma: no cover - compiled
    view: Array, ci: Flat, cj: Flat, resolution: float, cap: float
) -> None:
    """``view`` becomes its minimum with the clearance to the cells (``ci``, ``cj``) of it:
    each cell's squared distance (in cells) to the nearest of them, turned into metres as
    ``_compiled_map`` turns it, so the same numbers as transforming them."""
    half = 0.5 * resolution
    nx, ny = view.shape
    for i in range(nx):
        for j in range(ny):
            d2 = (i - ci[0]) * (i - ci[0]) + (j - cj[0]) * (j - cj[0])
            for k in range(1, ci.size):
                d2 = min(d2, (i - ci[k]) * (i - ci[k]) + (j - cj[k]) * (j - cj[k]))
            dist = min(max(math.sqrt(float(d2)) * resolution - half, 0.0), cap)
            view[i, j] = min(view[i, j], dist)


@occupancy_kernel.jit
def _lost(  # pragma: no cover - compiled
    view: Array, ri: Flat, rj: Flat, resolution: float, cap: float
) -> tuple[Flat, Flat]:
    """The cells of ``view`` that may have lost their nearest occupied cell when the cells
    (``ri``, ``rj``) of it stopped being occupied: those below ``cap`` whose clearance equals
    that to the nearest removed cell, measured as ``_compiled_map`` measures (the mapping from
    squared distance to clearance is non-decreasing, so any other cell kept its own nearest)."""
    half = 0.5 * resolution
    nx, ny = view.shape
    lost_i = np.empty(nx * ny, dtype=np.int64)
    lost_j = np.empty(nx * ny, dtype=np.int64)
    n = 0
    for i in range(nx):
        for j in range(ny):
            if view[i, j] >= cap:
                continue  # saturated: fewer occupied cells cannot bring it nearer
            d2 = (i - ri[0]) * (i - ri[0]) + (j - rj[0]) * (j - rj[0])
            for k in range(1, ri.size):
                d2 = min(d2, (i - ri[k]) * (i - ri[k]) + (j - rj[k]) * (j - rj[k]))
            if min(max(math.sqrt(float(d2)) * resolution - half, 0.0), cap) == view[i, j]:
                lost_i[n] = i
                lost_j[n] = j
                n += 1
    return lost_i[:n], lost_j[:n]


@occupancy_kernel.jit
def _remeasure(  # pragma: no cover - compiled
    view: Array,
    li: Flat,
    lj: Flat,
    occupied: NDArray[np.bool_],
    oi: int,
    oj: int,
    resolution: float,
    cap: float,
) -> tuple[int, int, int, int]:
    """The cells (``li``, ``lj``) of ``view`` measured again, as ``_compiled_map`` measures, to
    the occupied cells of ``occupied``: a window whose cell (0, 0) is ``view``'s (``oi``,
    ``oj``) and which holds every occupied cell that can be nearest to one of them. Returns the
    window of ``view`` that changed (empty: none)."""
    half = 0.5 * resolution
    mx, my = occupied.shape
    left_i = np.empty(mx * my, dtype=np.int64)
    left_j = np.empty(mx * my, dtype=np.int64)
    n_left = 0
    for a in range(mx):
        for b in range(my):
            if occupied[a, b]:
                left_i[n_left] = a - oi
                left_j[n_left] = b - oj
                n_left += 1
    nx, ny = view.shape
    i0, i1, j0, j1 = nx, 0, ny, 0
    for m in range(li.size):
        i, j = li[m], lj[m]
        dist = cap
        if n_left:
            d2 = (i - left_i[0]) * (i - left_i[0]) + (j - left_j[0]) * (j - left_j[0])
            for k in range(1, n_left):
                d2 = min(d2, (i - left_i[k]) * (i - left_i[k]) + (j - left_j[k]) * (j - left_j[k]))
            dist = min(max(math.sqrt(float(d2)) * resolution - half, 0.0), cap)
        if dist != view[i, j]:
            view[i, j] = dist
            i0, i1, j0, j1 = min(i0, i), max(i1, i + 1), min(j0, j), max(j1, j + 1)
    if i0 >= i1:
        return 0, 0, 0, 0
    return i0, i1, j0, j1


@occupancy_kernel.jit
def _extent(cells: Flat, ny: int) -> tuple[int, int, int, int]:  # pragma: no cover - compiled
    """The smallest and largest row and column of flat ``cells`` (at least one)."""
    lo_i, lo_j = cells[0] // ny, cells[0] % ny
    hi_i, hi_j = lo_i, lo_j
    for c in cells:
        i, j = c // ny, c % ny
        lo_i, hi_i = min(lo_i, i), max(hi_i, i)
        lo_j, hi_j = min(lo_j, j), max(hi_j, j)
    return lo_i, hi_i, lo_j, hi_j


REMOVE_FEW = 24  # removed cells looked for one by one (beyond: a transform of their window)
REMOVE_BUDGET = 4  # distance evaluations per cell of the transform ``_remeasure`` saves


class DistanceMap:
    """The clearance map of one occupancy layer, updated as cells are added or removed.

    The map is this object's own and is updated in place: ``get`` hands it out to be read
    there and then (the world model derives its own arrays from it), not kept.
    """

    def __init__(self, grid: Grid, cap: float) -> None:
        self.grid = grid
        self.cap = cap
        self._map: Array | None = None  # None: recompute from the layer on the next read
        # cells within this many of an added cell may get closer to something
        self._reach = math.ceil((cap + 0.5 * grid.resolution) / grid.resolution) + 1

    @property
    def ready(self) -> bool:
        """Whether the map is there (``get`` will not transform the whole layer)."""
        return self._map is not None

    def reset(self) -> None:
        """Forget the map: the next ``get`` transforms the whole layer."""
        self._map = None

    def window(self, cells: Flat, grow: int | None = None) -> Window:
        """The cells within ``grow`` (default: the reach) of flat ``cells``' bounding box."""
        r = self._reach if grow is None else grow
        if occupancy_kernel.AVAILABLE:
            lo_i, hi_i, lo_j, hi_j = _extent(cells, self.grid.ny)
        else:
            i, j = np.divmod(cells, self.grid.ny)
            lo_i, hi_i, lo_j, hi_j = int(i.min()), int(i.max()), int(j.min()), int(j.max())
        i0, i1 = max(lo_i - r, 0), min(hi_i + r + 1, self.grid.nx)
        j0, j1 = max(lo_j - r, 0), min(hi_j + r + 1, self.grid.ny)
        return i0, i1, j0, j1

    def add(self, occupied: NDArray[np.bool_], cells: Flat) -> Window | None:
        """Cells ``cells`` (flat indices) became occupied in ``occupied`` (the layer, after).
        Returns the window of the map that may have changed (``None``: none)."""
        if cells.size == 0:
            return None
        i0, i1, j0, j1 = self.window(cells)
        if self._map is not None:
            i, j = np.divmod(cells, self.grid.ny)
            view = self._map[i0:i1, j0:j1]
            if occupancy_kernel.AVAILABLE and cells.size <= FEW_CELLS:
                # a few cells: their distances directly, as the transform would find them
                _add_few(view, i - i0, j - j0, self.grid.resolution, self.cap)
            else:
                added = np.zeros((i1 - i0, j1 - j0), dtype=bool)
                added[i - i0, j - j0] = True
                near = clearance_map(added, self.grid.resolution, self.cap)
                np.minimum(view, near, out=view)
        return i0, i1, j0, j1

    def remove(self, layers: tuple[NDArray[np.bool_], ...], cells: Flat) -> Window | None:
        """Cells ``cells`` stopped being occupied; the layer (after) is the union of ``layers``.
        Returns the window of the map that may have changed (``None``: none)."""
        if cells.size == 0:
            return None
        i0, i1, j0, j1 = self.window(cells)
        if self._map is None:
            return i0, i1, j0, j1
        o0, o1, p0, p1 = self.window(cells, 2 * self._reach)
        occupied = layers[0][o0:o1, p0:p1]
        for layer in layers[1:]:
            occupied = occupied | layer[o0:o1, p0:p1]
        if occupancy_kernel.AVAILABLE and cells.size <= REMOVE_FEW:
            # only the cells that may have lost their nearest one are measured again
            view = self._map[i0:i1, j0:j1]
            i, j = np.divmod(cells, self.grid.ny)
            li, lj = _lost(view, i - i0, j - j0, self.grid.resolution, self.cap)
            if li.size == 0:
                return None
            if li.size * np.count_nonzero(occupied) <= REMOVE_BUDGET * occupied.size:
                args = (occupied, i0 - o0, j0 - p0, self.grid.resolution, self.cap)
                c0, c1, d0, d1 = _remeasure(view, li, lj, *args)
                return (i0 + c0, i0 + c1, j0 + d0, j0 + d1) if c0 < c1 else None
            # many: the transform over their window (grown by the reach, inside the outer one)
            i0, i1 = i0 + int(li.min()), i0 + int(li.max()) + 1
            j0, j1 = j0 + int(lj.min()), j0 + int(lj.max()) + 1
            r = self._reach
            a0, a1 = max(i0 - r, o0), min(i1 + r, o1)
            b0, b1 = max(j0 - r, p0), min(j1 + r, p1)
            occupied, (o0, o1, p0, p1) = (
                occupied[a0 - o0 : a1 - o0, b0 - p0 : b1 - p0],
                (a0, a1, b0, b1),
            )
        near = clearance_map(occupied, self.grid.resolution, self.cap)
        self._map[i0:i1, j0:j1] = near[i0 - o0 : i1 - o0, j0 - p0 : j1 - p0]
        return i0, i1, j0, j1

    def get(self, *layers: NDArray[np.bool_]) -> Array:
        """The clearance map of the union of ``layers`` (the layer as it is now)."""
        if self._map is None:
            occupied = layers[0]
            for layer in layers[1:]:
                occupied = occupied | layer
            self._map = clearance_map(occupied, self.grid.resolution, self.cap)
        return self._map

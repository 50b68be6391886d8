"""Cell geometry of the world model's grids: cells, centres, flat indices of world points."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sim.robot import Array
from sim.world import Bounds

Flat = NDArray[np.intp]


class Grid:
    """Cell geometry: cell ``[i, j]`` spans ``origin + ([i, i+1], [j, j+1]) * resolution``.

    The grid covers the bounds; when they are not a whole number of cells the last row and column
    overhang them.
    """

    def __init__(self, bounds: Bounds, resolution: float) -> None:
        self.bounds = bounds
        self.resolution = resolution
        self.origin = (bounds.xmin, bounds.ymin)
        self.nx = max(1, math.ceil((bounds.xmax - bounds.xmin) / resolution - 1e-9))
        self.ny = max(1, math.ceil((bounds.ymax - bounds.ymin) / resolution - 1e-9))
        self.xs = bounds.xmin + (np.arange(self.nx) + 0.5) * resolution  # cell centres
        self.ys = bounds.ymin + (np.arange(self.ny) + 0.5) * resolution

    @property
    def shape(self) -> tuple[int, int]:
        """``(nx, ny)``: cells along x, along y."""
        return (self.nx, self.ny)

    def cell_of(self, x: float, y: float) -> tuple[int, int]:
        """The cell holding a world point (indices may fall outside the grid; see ``inside``)."""
        res = self.resolution
        return (math.floor((x - self.origin[0]) / res), math.floor((y - self.origin[1]) / res))

    def inside(self, i: int, j: int) -> bool:
        """Whether cell ``(i, j)`` is on the grid."""
        return 0 <= i < self.nx and 0 <= j < self.ny

    def centre_of(self, i: int, j: int) -> tuple[float, float]:
        """The world centre of cell ``(i, j)``."""
        res = self.resolution
        return (self.origin[0] + (i + 0.5) * res, self.origin[1] + (j + 0.5) * res)

    def centres(self, flat: Flat) -> Array:
        """World centres ``[N, 2]`` of flat cell indices."""
        i, j = np.divmod(flat, self.ny)
        return np.stack([self.xs[i], self.ys[j]], axis=-1)

    def flat_of(self, points: Array) -> Flat:
        """Flat indices of the cells holding points ``[N, 2]``; points outside the grid dropped."""
        flat, keep = self.locate(points)
        out: Flat = flat[keep]
        return out

    def locate(self, points: Array) -> tuple[Flat, NDArray[np.bool_]]:
        """Flat indices of the cells holding points ``[N, 2]`` and which points lie in the grid."""
        res = self.resolution
        i = np.floor((points[:, 0] - self.origin[0]) / res).astype(np.intp)
        j = np.floor((points[:, 1] - self.origin[1]) / res).astype(np.intp)
        keep = (i >= 0) & (i < self.nx) & (j >= 0) & (j < self.ny)
        flat: Flat = i * self.ny + j
        return flat, keep


# np.unique on the few hundred cell indices of one update spends most of its time in set-up
# (numpy 2's hash path); sorting and comparing neighbours gives the same sorted answers faster.
def unique_cells(cells: Flat) -> Flat:
    """Sorted distinct values of ``cells`` (as ``np.unique``)."""
    ordered = np.sort(cells)
    first = np.empty(ordered.shape, dtype=bool)
    first[:1] = True
    np.not_equal(ordered[1:], ordered[:-1], out=first[1:])
    out: Flat = ordered[first]
    return out


def unique_counts(cells: Flat) -> tuple[Flat, Flat]:
    """Sorted distinct values of ``cells`` and how often each occurs (as ``np.unique``)."""
    ordered = np.sort(cells)
    first = np.empty(ordered.shape, dtype=bool)
    first[:1] = True
    np.not_equal(ordered[1:], ordered[:-1], out=first[1:])
    starts = np.flatnonzero(first)
    counts: Flat = np.diff(np.append(starts, ordered.size))
    return ordered[starts], counts


def unique_inverse(cells: Flat) -> tuple[Flat, Flat]:
    """Sorted distinct values of ``cells`` and each element's index among them (as ``np.unique``)."""
    order = np.argsort(cells, kind="stable")
    ordered = cells[order]
    first = np.empty(ordered.shape, dtype=bool)
    first[:1] = True
    np.not_equal(ordered[1:], ordered[:-1], out=first[1:])
    inverse = np.empty(cells.shape, dtype=np.intp)
    inverse[order] = np.cumsum(first) - 1
    out: Flat = ordered[first]
    return out, inverse


def cells_round(
    xs: NDArray[np.floating[Any]],
    ys: NDArray[np.floating[Any]],
    point: tuple[float, float],
    radius: float,
) -> tuple[Flat, Flat, Array]:
    """The cells of the box round ``point`` that may lie within ``radius`` of it (centres
    ``xs[i]``, ``ys[j]``, both ascending; a cell more each side for rounding), ``i`` then ``j``
    ascending, with each centre's distance to the point: a disc's cells found without
    measuring the whole grid."""
    i0 = max(0, int(np.searchsorted(xs, point[0] - radius)) - 1)
    i1 = min(len(xs), int(np.searchsorted(xs, point[0] + radius, side="right")) + 1)
    j0 = max(0, int(np.searchsorted(ys, point[1] - radius)) - 1)
    j1 = min(len(ys), int(np.searchsorted(ys, point[1] + radius, side="right")) + 1)
    box_i, box_j = np.meshgrid(np.arange(i0, i1), np.arange(j0, j1), indexing="ij")
    i: Flat = box_i.ravel()
    j: Flat = box_j.ravel()
    distance: Array = np.hypot(xs[i] - point[0], ys[j] - point[1])
    return i, j, distance

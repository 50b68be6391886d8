"""A clearance callable's compiled form: the grids it reads, for kernels that sample it per point.

A planner's clearance is a Python callable (world points -> metres), bilinear between the cell
centres of a world model's grid and at most the distance to the walls
(``domain.interpolate.bilinear``). A compiled search cannot call back into Python for every
swept sample point, so a clearance can also hand out ``ClearanceGrids``: the grid values, where
the grid lies and the wall box. ``bilinear_at`` evaluates it at one point with
``interpolate._compiled``'s arithmetic, so it gives the callable's answer value for value (a test
holds it to that).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from domain.grid import Grid
from domain.occupancy_kernel import _jit
from sim.robot import Array
from sim.world import Bounds


def _read_only(values: Array) -> Array:
    """A read-only C-contiguous view: one compiled signature whether or not the owner's array
    is writeable (and a kernel cannot write to it)."""
    out = np.ascontiguousarray(values, dtype=np.float64).view()
    out.flags.writeable = False
    return out


@dataclass(frozen=True)
class ClearanceGrids:
    """A clearance as a grid: ``values`` ``[nx, ny]`` at the cell centres of a grid whose first
    cell's corner is ``origin`` with cells ``resolution`` wide, at most the distance to the wall
    box ``walls``."""

    values: Array
    origin: tuple[float, float]
    resolution: float
    walls: tuple[float, float, float, float]  # xmin, xmax, ymin, ymax

    @classmethod
    def of(
        cls,
        values: Array,
        grid: Grid,
        walls: Bounds,
    ) -> ClearanceGrids:
        """The form of ``bilinear(values, grid, points, walls)``."""
        return cls(
            _read_only(values),
            (float(grid.origin[0]), float(grid.origin[1])),
            float(grid.resolution),
            (walls.xmin, walls.xmax, walls.ymin, walls.ymax),
        )

    @property
    def geometry(self) -> Array:
        """``[ox, oy, resolution, xmin, xmax, ymin, ymax]`` as the kernels take it."""
        return np.array([*self.origin, self.resolution, *self.walls])

    def __call__(self, pts: Array) -> Array:
        """The clearance at points ``[..., 2]`` (the compiled evaluation, for checks)."""
        points = np.ascontiguousarray(pts, dtype=np.float64)
        flat = points.reshape(-1, 2)
        out = np.empty(flat.shape[0])
        _many(self.values, self.geometry, flat, out)
        return out.reshape(points.shape[:-1])


class GridClearance:
    """A clearance callable that also hands out its compiled form (``grids()``, taken when a
    search starts: the world's grids as they are then)."""

    def __init__(self, fn: Callable[[Array], Array], grids: Callable[[], ClearanceGrids]) -> None:
        self._fn, self._grids = fn, grids

    def __call__(self, pts: Array) -> Array:
        return self._fn(pts)

    def grids(self) -> ClearanceGrids:
        """The grids this clearance reads, as they are now."""
        return self._grids()


def has_grids(clearance: object) -> bool:
    """Whether a clearance callable has a compiled form."""
    return isinstance(clearance, GridClearance)


def grids_of(clearance: object) -> ClearanceGrids | None:
    """The compiled form of a clearance callable, if it has one (else ``None``)."""
    return clearance.grids() if isinstance(clearance, GridClearance) else None


def world_clearance(world: object) -> GridClearance:
    """A world model's plain ``clearance_at`` with its compiled form (public reads only)."""
    w: object = world

    def grids() -> ClearanceGrids:
        return ClearanceGrids.of(w.clearance(), w.grid, w.bounds)  # type: ignore[attr-defined]

    return GridClearance(w.clearance_at, grids)  # type: ignore[attr-defined]


@_jit
def bilinear_at(  # pragma: no cover - compiled
    values: Array, geo: Array, x: float, y: float
) -> float:
    """``interpolate._compiled`` at one point (the same operations in the same order)."""
    nx, ny = values.shape
    ox, oy, res = geo[0], geo[1], geo[2]
    u = min(max((x - ox) / res - 0.5, 0.0), nx - 1.0)
    v = min(max((y - oy) / res - 0.5, 0.0), ny - 1.0)
    i0 = min(int(u), max(nx - 2, 0))
    j0 = min(int(v), max(ny - 2, 0))
    fu, fv = u - i0, v - j0
    i1 = i0 + 1 if nx > 1 else i0
    j1 = j0 + 1 if ny > 1 else j0
    low = values[i0, j0] * (1 - fv) + values[i0, j1] * fv
    high = values[i1, j0] * (1 - fv) + values[i1, j1] * fv
    wall = min(min(x - geo[3], geo[4] - x), min(y - geo[5], geo[6] - y))
    return float(min(low * (1 - fu) + high * fu, wall))


@_jit
def _many(  # pragma: no cover - compiled
    values: Array, geo: Array, pts: Array, out: Array
) -> None:
    for p in range(pts.shape[0]):
        out[p] = bilinear_at(values, geo, pts[p, 0], pts[p, 1])

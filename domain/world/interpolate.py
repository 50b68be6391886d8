"""Bilinear interpolation of a cell-centred grid at many points (numpy, or a compiled kernel).

Planners and the plan guard sample the world model's clearance at thousands of points per
search; numpy does it in a dozen passes with as many temporary arrays. The numba kernel does it
in one loop with the same arithmetic, element by element (no fast-math), so it gives the numpy
answer value for value (``tests/domain/test_occupancy_kernel.py`` holds it to that). It runs
when numba is there (``domain.occupancy_kernel.AVAILABLE``, off with ``SCREWSNAKE_KERNELS=numpy``).
"""

from __future__ import annotations

import numpy as np

from domain import kernels as occupancy_kernel
from domain.world.grid import Grid
from sim.robot import Array
from sim.world import Bounds

__all__ = ["bilinear"]


def bilinear(values: Array, grid: Grid, pts: Array, walls: Bounds | None = None) -> Array:
    """``values`` ``[nx, ny]`` (one per cell centre of ``grid``) between cell centres at points
    ``[..., 2]``, nearest beyond the outer centres; with ``walls``, at most each point's
    distance to them (``np.minimum`` with ``walls.wall_clearance``, negative outside)."""
    if occupancy_kernel.AVAILABLE and values.flags.c_contiguous:
        points = np.ascontiguousarray(pts, dtype=float)
        out = np.empty(points.shape[:-1])
        box = (walls.xmin, walls.xmax, walls.ymin, walls.ymax) if walls is not None else _NO_WALLS
        origin = grid.origin
        _compiled(
            values, points.reshape(-1, 2), origin[0], origin[1], grid.resolution, *box, out.ravel()
        )
        return out
    inner = _numpy(values, grid, pts)
    if walls is None:
        return inner
    out_np: Array = np.minimum(inner, walls.wall_clearance(pts))
    return out_np


_NO_WALLS = (-np.inf, np.inf, -np.inf, np.inf)  # nothing is near walls at infinity


def _numpy(values: Array, grid: Grid, pts: Array) -> Array:
    """The numpy path (by fancy indexing), the reference of the compiled one."""
    res = grid.resolution
    nx, ny = values.shape
    u = np.clip((pts[..., 0] - grid.origin[0]) / res - 0.5, 0.0, nx - 1.0)
    v = np.clip((pts[..., 1] - grid.origin[1]) / res - 0.5, 0.0, ny - 1.0)
    i0 = np.minimum(u.astype(np.intp), max(nx - 2, 0))
    j0 = np.minimum(v.astype(np.intp), max(ny - 2, 0))
    fu, fv = u - i0, v - j0
    flat = values.ravel()
    base = i0 * ny + j0
    di, dj = (ny if nx > 1 else 0), (1 if ny > 1 else 0)
    low = flat[base] * (1 - fv) + flat[base + dj] * fv
    high = flat[base + di] * (1 - fv) + flat[base + di + dj] * fv
    out: Array = low * (1 - fu) + high * fu
    return out


@occupancy_kernel.jit
def _compiled(  # pragma: no cover - compiled
    values: Array,
    pts: Array,
    ox: float,
    oy: float,
    res: float,
    xmin: float,
    xmax: float,
    ymin: float,
    ymax: float,
    out: Array,
) -> None:
    """``_numpy`` for points ``[P, 2]`` into ``out`` ``[P]``, one loop, the same operations,
    then the minimum with the distance to the walls (as ``Bounds.wall_clearance``)."""
    nx, ny = values.shape
    flat = values.ravel()
    i_top, j_top = max(nx - 2, 0), max(ny - 2, 0)
    di = ny if nx > 1 else 0
    dj = 1 if ny > 1 else 0
    for k in range(pts.shape[0]):
        u = min(max((pts[k, 0] - ox) / res - 0.5, 0.0), nx - 1.0)
        v = min(max((pts[k, 1] - oy) / res - 0.5, 0.0), ny - 1.0)
        i0 = min(int(u), i_top)
        j0 = min(int(v), j_top)
        fu, fv = u - i0, v - j0
        base = i0 * ny + j0
        low = flat[base] * (1 - fv) + flat[base + dj] * fv
        high = flat[base + di] * (1 - fv) + flat[base + di + dj] * fv
        x, y = pts[k, 0], pts[k, 1]
        wall = min(min(x - xmin, xmax - x), min(y - ymin, ymax - y))
        out[k] = min(low * (1 - fu) + high * fu, wall)

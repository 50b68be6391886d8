"""Bilinear interpolation of a cell-centred grid at many points, compiled (numba).

Planners and the plan guard sample the world model's clearance at thousands of points per
search (``WorldModel._interpolate``); numpy does it in a dozen passes with as many temporary
arrays. ``bilinear`` does it in one loop with the same arithmetic, element by element (no
fast-math), so it gives the numpy answer value for value; ``tests/domain/test_occupancy_kernel.py``
holds it to that. ``AVAILABLE`` is False without numba or with ``SCREWSNAKE_KERNELS=numpy``.
"""

from __future__ import annotations

from domain.occupancy_kernel import AVAILABLE, _jit
from sim.robot import Array

__all__ = ["AVAILABLE", "bilinear"]


@_jit
def bilinear(  # pragma: no cover - compiled
    grid: Array, pts: Array, ox: float, oy: float, res: float, out: Array
) -> None:
    """``out[k]`` = the grid ``[nx, ny]`` between cell centres at ``pts[k]`` (``[P, 2]``),
    nearest beyond the outer centres, as ``WorldModel._interpolate`` computes it."""
    nx, ny = grid.shape
    flat = grid.ravel()
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
        out[k] = low * (1 - fu) + high * fu

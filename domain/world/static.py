"""The static layer's geometry: exact distances from cell centres to a known obstacle.

A polygon's distances are those to its nearest edge (0 inside, by the even-odd rule), computed
cell by cell in one compiled call when numba is there: a known obstacle's block reaches the
clearance cap (2 m by default) on each side, thousands of cells times each edge, which numpy's
many passes over the block took milliseconds per obstacle for. The numpy path does the same
arithmetic element by element (no BLAS product, whose fused multiply-adds round otherwise),
so both give the same floats.
"""

from __future__ import annotations

import math

import numpy as np

from domain.kernels import AVAILABLE, jit
from domain.world.grid import Grid
from sim.obstacles import Circle, Obstacle
from sim.robot import Array


def distance_block(
    obstacle: Obstacle, grid: Grid, cap: float
) -> tuple[tuple[int, int, int, int], Array] | None:
    """Exact distances (0 inside) from the cell centres within ``cap`` of the obstacle's bounding
    box to the obstacle, capped at ``cap``; ``None`` if no centre is that close."""
    x0, y0, x1, y1 = obstacle.bounding_box()
    i0, i1 = np.searchsorted(grid.xs, [x0 - cap, x1 + cap], side="left")
    j0, j1 = np.searchsorted(grid.ys, [y0 - cap, y1 + cap], side="left")
    if i0 >= i1 or j0 >= j1:
        return None
    xs, ys = grid.xs[i0:i1], grid.ys[j0:j1]
    if isinstance(obstacle, Circle):
        x, y = np.meshgrid(xs, ys, indexing="ij")
        dist = np.hypot(x - obstacle.x, y - obstacle.y) - obstacle.radius
    else:
        ea, eb = (np.ascontiguousarray(e, dtype=float) for e in obstacle.edges)
        dist = polygon_distances(np.ascontiguousarray(xs), np.ascontiguousarray(ys), ea, eb)
    return (int(i0), int(i1), int(j0), int(j1)), np.clip(dist, 0.0, cap)


def polygon_distances(xs: Array, ys: Array, ea: Array, eb: Array) -> Array:
    """Distances ``[len(xs), len(ys)]`` from the points of the grid ``xs x ys`` to the polygon
    of edges ``ea-eb`` ``[E, 2]``: to its nearest edge, 0 inside (even-odd rule)."""
    if AVAILABLE:
        out = np.empty((xs.size, ys.size))
        _polygon_distances(xs, ys, ea, eb, out)
        return out
    x, y = np.meshgrid(xs, ys, indexing="ij")
    best = np.full(x.shape, np.inf)
    crossings = np.zeros(x.shape, dtype=np.int64)
    for (ax, ay), (bx, by) in zip(ea.tolist(), eb.tolist(), strict=True):
        abx, aby = bx - ax, by - ay
        den = max(abx * abx + aby * aby, 1e-12)
        px, py = x - ax, y - ay
        s = np.clip((px * abx + py * aby) / den, 0.0, 1.0)
        dx, dy = px - s * abx, py - s * aby
        np.minimum(best, np.sqrt(dx * dx + dy * dy), out=best)
        straddle = (ay > y) != (by > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            x_cross = ax + (y - ay) * (bx - ax) / (by - ay)
        crossings += straddle & (x < x_cross)
    inside: Array = np.where(crossings % 2 == 1, 0.0, best)
    return inside


@jit
def _polygon_distances(  # pragma: no cover - compiled
    xs: Array, ys: Array, ea: Array, eb: Array, out: Array
) -> None:
    """``polygon_distances`` into ``out``, cell by cell, the same arithmetic."""
    for i in range(xs.size):
        for j in range(ys.size):
            x, y = xs[i], ys[j]
            best = math.inf
            crossings = 0
            for e in range(ea.shape[0]):
                ax, ay, bx, by = ea[e, 0], ea[e, 1], eb[e, 0], eb[e, 1]
                abx, aby = bx - ax, by - ay
                den = max(abx * abx + aby * aby, 1e-12)
                px, py = x - ax, y - ay
                s = min(max((px * abx + py * aby) / den, 0.0), 1.0)
                dx, dy = px - s * abx, py - s * aby
                d = math.sqrt(dx * dx + dy * dy)
                if d < best:
                    best = d
                if (ay > y) != (by > y) and x < ax + (y - ay) * (bx - ax) / (by - ay):
                    crossings += 1
            out[i, j] = 0.0 if crossings % 2 == 1 else best

"""The static layer's geometry: exact distances from cell centres to a known obstacle."""

from __future__ import annotations

import numpy as np

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
    x, y = np.meshgrid(grid.xs[i0:i1], grid.ys[j0:j1], indexing="ij")
    pts = np.stack([x, y], axis=-1)
    if isinstance(obstacle, Circle):
        dist = np.hypot(x - obstacle.x, y - obstacle.y) - obstacle.radius
    else:
        ea, eb = obstacle.edges
        dist = _point_edges_distance(pts, ea, eb)
        dist = np.where(obstacle.contains(pts), 0.0, dist)
    return (int(i0), int(i1), int(j0), int(j1)), np.clip(dist, 0.0, cap)


def _point_edges_distance(pts: Array, ea: Array, eb: Array) -> Array:
    """Distance from points ``[..., 2]`` to the nearest of the edges ``ea-eb`` ``[E, 2]``."""
    best = np.full(pts.shape[:-1], np.inf)
    for a, b in zip(ea, eb, strict=True):  # a loop over edges, each vectorised over cells
        ab = b - a
        s = np.clip(((pts - a) @ ab) / max(float(ab @ ab), 1e-12), 0.0, 1.0)
        np.minimum(best, np.linalg.norm(pts - a - s[..., None] * ab, axis=-1), out=best)
    return best

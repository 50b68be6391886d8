"""Known obstacles against the grid: exact distances from cell centres (the static layer) and
exact capsule checks where the grid cannot decide."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from domain.grid import Grid
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


def obstacle_clear(
    obstacle: Obstacle, a: Array, b: Array, need: Array, ok: NDArray[np.bool_]
) -> None:
    """Clear ``ok`` (``[B]``) where a capsule of ``a-b`` ``[B, C, 2]`` comes within ``need`` of
    the obstacle; only capsules whose bounding boxes come near it are measured."""
    x0, y0, x1, y1 = obstacle.bounding_box()
    lo, hi = np.minimum(a, b) - need[:, None], np.maximum(a, b) + need[:, None]
    near = (lo[..., 0] <= x1) & (hi[..., 0] >= x0) & (lo[..., 1] <= y1) & (hi[..., 1] >= y0)
    rows = np.flatnonzero(np.any(near, axis=-1) & ok)
    if rows.size:
        gap = obstacle.segment_clearance(a[rows], b[rows])  # [R, C]
        ok[rows[np.any(gap < need, axis=-1)]] = False


def axis_samples(a: Array, b: Array, step: float) -> Array:
    """Points along each capsule axis ``a-b`` ``[..., C, 2]``: ``[..., C, n, 2]``, at most
    ``step`` apart."""
    length = float(np.max(np.linalg.norm(b - a, axis=-1), initial=0.0))
    t = np.linspace(0.0, 1.0, max(2, int(np.ceil(length / step)) + 1))
    points: Array = a[..., None, :] + t[:, None] * (b - a)[..., None, :]
    return points


def known_capsules_clear(
    known: Sequence[Obstacle],
    a: Array,
    b: Array,
    nearest: Array,
    need: Array,
    resolution: float,
    ok: NDArray[np.bool_],
) -> None:
    """Clear ``ok`` ``[B]`` where a capsule ``a-b`` ``[B, C, 2]`` comes within ``need`` of a known
    obstacle; ``nearest`` ``[B, C]`` is the static clearance interpolated at its axis samples,
    minimised along the axis (samples a quarter cell apart at most).

    The exact static clearance at cell centres is 1-Lipschitz, so its interpolation at the
    axis samples bounds the true clearance on the axis within half a cell diagonal plus a
    quarter cell (the samples' spacing): capsules far from known geometry pass, capsules deep
    in it fail, and only the rest are measured exactly against the obstacles.
    """
    corner = resolution * math.sqrt(0.5)
    blocked = np.any(nearest + corner < need, axis=-1)
    unsure = np.flatnonzero(
        ok & ~blocked & np.any(nearest - corner - resolution / 4 < need, axis=-1)
    )
    ok &= ~blocked
    if unsure.size:
        sub = np.ones(unsure.size, dtype=bool)
        for obstacle in known:
            obstacle_clear(obstacle, a[unsure], b[unsure], need, sub)
        ok[unsure] = sub

"""The observed layer: cells a beam crossed or the body covered, as against never-observed space.

Only the head senses: its rays start at the head tip, so most of the space the trailing body
sweeps (beside it, behind it, wherever it swings in a turn) was never looked at. The planner
pays for sweeping such space unseen (``domain.navigation``'s motion costs); this layer tells it
apart. A cell is observed once a reading's beam crossed it (cleared it, or placed its hit
there) or the body covered it: where the body is, nothing else can be.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from domain.kernels import AVAILABLE, jit
from domain.world.grid import Flat, Grid, unique_cells
from sim.robot import DEFAULT_GEOMETRY, RobotGeometry
from sim.world import footprint


class ObservedLayer:
    """Which cells were ever observed, and how many."""

    def __init__(self, grid: Grid) -> None:
        self.grid = grid
        self.observed = np.zeros(grid.shape, dtype=bool)
        self.count = 0

    def observe(self, cells: Flat) -> bool:
        """Mark ``cells`` (flat) observed; whether any was not yet."""
        if not cells.size:
            return False
        flat = self.observed.reshape(-1)
        if AVAILABLE:
            new = int(_mark(flat, cells))
        else:
            fresh = unique_cells(cells[~flat[cells]])
            flat[fresh] = True
            new = int(fresh.size)
        self.count += new
        return new > 0


@jit
def _mark(flat: NDArray[np.bool_], cells: Flat) -> int:  # pragma: no cover - compiled
    """Set ``flat`` at ``cells`` (repeats allowed); how many distinct cells were not set yet
    (one call per update: a tick's few hundred cells cost less than numpy's set-up)."""
    new = 0
    for c in cells:
        if not flat[c]:
            flat[c] = True
            new += 1
    return new


def body_cells(
    grid: Grid,
    pose: tuple[float, float, float],
    joints: tuple[float, float, float],
    geometry: RobotGeometry = DEFAULT_GEOMETRY,
) -> Flat:
    """The cells (flat, sorted) lying wholly inside the body at ``pose``: their centres keep
    half a cell diagonal inside a capsule, so no part of them can hold an obstacle (a cell the
    body merely overlaps may hold the surface it touches)."""
    fp = footprint(np.asarray(pose, dtype=float), np.asarray(joints, dtype=float), geometry)
    inner = np.ascontiguousarray(fp.radii - grid.resolution * math.sqrt(0.5), dtype=np.float64)
    geo = np.array([grid.origin[0], grid.origin[1], grid.resolution])
    out: Flat = _inside(
        np.ascontiguousarray(fp.starts, dtype=np.float64),
        np.ascontiguousarray(fp.ends, dtype=np.float64),
        inner,
        geo,
        grid.nx,
        grid.ny,
    ).astype(np.intp)
    return out


@jit
def _inside(  # pragma: no cover - compiled
    a: NDArray[np.float64],
    b: NDArray[np.float64],
    inner: NDArray[np.float64],
    geo: NDArray[np.float64],
    nx: int,
    ny: int,
) -> NDArray[np.int64]:
    """The cells whose centres lie within ``inner`` of a capsule axis ``a-b``, each once,
    sorted."""
    ox, oy, res = geo[0], geo[1], geo[2]
    x0, y0 = np.inf, np.inf
    x1, y1 = -np.inf, -np.inf
    for c in range(a.shape[0]):
        r = max(inner[c], 0.0)
        x0 = min(x0, min(a[c, 0], b[c, 0]) - r)
        y0 = min(y0, min(a[c, 1], b[c, 1]) - r)
        x1 = max(x1, max(a[c, 0], b[c, 0]) + r)
        y1 = max(y1, max(a[c, 1], b[c, 1]) + r)
    i0 = max(int(math.floor((x0 - ox) / res)), 0)
    j0 = max(int(math.floor((y0 - oy) / res)), 0)
    i1 = min(int(math.floor((x1 - ox) / res)) + 1, nx)
    j1 = min(int(math.floor((y1 - oy) / res)) + 1, ny)
    out = np.empty(max(0, i1 - i0) * max(0, j1 - j0), dtype=np.int64)
    n = 0
    for i in range(i0, i1):
        cx = ox + (i + 0.5) * res
        for j in range(j0, j1):
            cy = oy + (j + 0.5) * res
            for c in range(a.shape[0]):
                if inner[c] <= 0.0:
                    continue
                abx, aby = b[c, 0] - a[c, 0], b[c, 1] - a[c, 1]
                length2 = abx * abx + aby * aby
                t = 0.0
                if length2 > 1e-12:
                    t = min(max(((cx - a[c, 0]) * abx + (cy - a[c, 1]) * aby) / length2, 0.0), 1.0)
                dx, dy = cx - a[c, 0] - t * abx, cy - a[c, 1] - t * aby
                if dx * dx + dy * dy <= inner[c] * inner[c]:
                    out[n] = i * ny + j
                    n += 1
                    break
    return out[:n]

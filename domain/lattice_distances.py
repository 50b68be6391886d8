"""Footprint-aware 2-D distances on the lattice's cells: the relaxation that decides most
unreachable goals before any search, the search heuristic and the goal-to-goal distance table.

Dijkstra (scipy's csgraph) over the cells the body centroid can occupy, 8-connected.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from domain.lattice import LatticeGrid, MotionTable
from domain.lattice_task import Clearance
from sim.robot import Array
from sim.world import footprint

NEIGHBOURS = ((1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1))
START_FREE = 0.15  # metres around the start centroid that the 2-D relaxation always lets through


def centroid_need(table: MotionTable) -> float:
    """Clearance the centroid itself needs: how deep it lies inside the body's capsules."""
    fp = footprint(np.zeros(3), table.joints, table.geometry)
    c = table.offset
    ab = fp.ends - fp.starts
    s = np.clip(np.sum((c - fp.starts) * ab, -1) / np.maximum(np.sum(ab * ab, -1), 1e-12), 0, 1)
    d = np.linalg.norm(fp.starts + s[:, None] * ab - c, axis=-1)
    return float(max(0.0, np.max(fp.radii - d)))


def distance_map(
    grid: LatticeGrid,
    clearance: Clearance,
    goal: tuple[float, float],
    need: float,
    free: float,
    start: tuple[float, float] | None = None,
) -> Array:
    """Geodesic distance (m) from ``goal`` to every cell over cells whose centre keeps
    ``need`` clear (less the half-cell the centroid may sit off a centre); cells within ``free``
    of the goal (where the body reaches the goal with its head) are passable."""
    nx, ny, r = grid.nx, grid.ny, grid.settings.resolution
    xs = grid.bounds.xmin + (np.arange(nx) + 0.5) * r
    ys = grid.bounds.ymin + (np.arange(ny) + 0.5) * r
    cx, cy = np.meshgrid(xs, ys, indexing="ij")
    centres = np.stack([cx.ravel(), cy.ravel()], -1)
    ok = clearance(centres) >= need - r * math.sqrt(0.5)
    ok |= np.hypot(centres[:, 0] - goal[0], centres[:, 1] - goal[1]) <= free
    if start is not None:  # the robot is there: it may be touching what it just bumped into
        ok |= np.hypot(centres[:, 0] - start[0], centres[:, 1] - start[1]) <= START_FREE
    ok = ok.reshape(nx, ny)
    index = np.arange(nx * ny).reshape(nx, ny)
    rows, cols, weights = [], [], []
    for di, dj in NEIGHBOURS:
        a = ok[max(0, -di) : nx - max(0, di), max(0, -dj) : ny - max(0, dj)]
        b = ok[max(0, di) : nx - max(0, -di) : 1, max(0, dj) : ny - max(0, -dj)]
        both = a & b
        ia = index[max(0, -di) : nx - max(0, di), max(0, -dj) : ny - max(0, dj)][both]
        ib = index[max(0, di) : nx - max(0, -di), max(0, dj) : ny - max(0, -dj)][both]
        rows.append(ia)
        cols.append(ib)
        weights.append(np.full(ia.size, r * math.hypot(di, dj)))
    graph = coo_matrix(
        (np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))),
        shape=(nx * ny, nx * ny),
    ).tocsr()
    gi, gj = grid.cell(*goal)
    dist = dijkstra(graph, directed=True, indices=int(index[gi, gj]))
    return np.asarray(dist, dtype=float).reshape(nx, ny)

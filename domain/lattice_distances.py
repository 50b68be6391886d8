"""Footprint-aware 2-D distances on the lattice's cells: the relaxation that decides most
unreachable goals before any search, the search heuristic and the goal-to-goal distance table.

Dijkstra over the cells the body centroid can occupy, 8-connected: a compiled grid search
(domain/lattice_kernels.py), or scipy's csgraph without numba.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray
from scipy.sparse import coo_matrix, csr_matrix
from scipy.sparse.csgraph import dijkstra

from domain import lattice_kernels
from domain.grid import cells_round
from domain.lattice import LatticeGrid, MotionTable
from sim.robot import DEFAULT_GEOMETRY, Array
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
    at_centres: Array,
    goal: tuple[float, float],
    need: float,
    free: float,
    start: tuple[float, float] | None = None,
) -> Array:
    """Geodesic distance (m) from ``goal`` to every cell over cells whose centre keeps
    ``need`` clear (``at_centres``: the clearance at ``grid.centres``; less the half-cell the
    centroid may sit off a centre); cells within ``free`` of the goal (where the body reaches
    the goal with its head) are passable."""
    r = grid.settings.resolution
    ok = at_centres >= need - r * math.sqrt(0.5)
    return _from_goal(grid, goal, ok | _passable_anyway(grid, at_centres, goal, free, start))


def _passable_anyway(
    grid: LatticeGrid,
    at_centres: Array,
    goal: tuple[float, float],
    free: float,
    start: tuple[float, float] | None,
) -> NDArray[np.bool_]:
    """The cells a distance map passes whatever their clearance: within ``free`` of the goal
    with a straight way to it (``_in_reach``), and the robot's own round ``start``."""
    out = _in_reach(grid, at_centres, goal, free)
    if start is not None:  # the robot is there: it may be touching what it just bumped into
        out[cells_within(grid, start, START_FREE)] = True
    return out


def _from_goal(grid: LatticeGrid, goal: tuple[float, float], ok: NDArray[np.bool_]) -> Array:
    """Geodesic distances from ``goal``'s cell over the cells where ``ok`` (``[nx * ny]``)."""
    gi, gj = grid.cell(*goal)
    return geodesic(ok.reshape(grid.nx, grid.ny), [(gi, gj)], grid.settings.resolution)


def turn_room(table: MotionTable) -> float:
    """How far sideways the resting body's farthest point from the centroid moves in one
    orientation step: the room a passage leaves the body to change its heading at all."""
    farthest = max(float(np.max(np.hypot(p[:, 0], p[:, 1]))) for p in table.body_points)
    return 2.0 * farthest * math.sin(table.settings.step / 2)


def roomy_map(
    grid: LatticeGrid,
    at_centres: Array,
    goal: tuple[float, float],
    table: MotionTable,
    margin: float,
    free: float,
    start: tuple[float, float],
    relaxed: Array,
) -> Array:
    """The distance map of a way with room: over the cells whose centre keeps the centroid's
    need, the margin and ``turn_room`` (not relaxed); every other cell ``relaxed`` (the usual
    map) reaches costs that much more than any cell of the roomy way, so a greedy search takes
    the roomy way where it has one and still finds any other. Where no cell with room is
    passable but those always are (the goal's reach, the start's), the map would be
    ``relaxed`` plus a constant, the same greedy search: it is ``relaxed`` itself."""
    need = centroid_need(table) + margin + turn_room(table)
    always = _passable_anyway(grid, at_centres, goal, free, start)
    roomy = _from_goal(grid, goal, (at_centres >= need) | always)  # (no half-cell relaxation)
    # (A later leg's start is not the one ``relaxed`` let through: what it cuts off stays so.)
    finite = np.isfinite(roomy) & np.isfinite(relaxed)
    gi, gj = grid.cell(*goal)
    always[gi * grid.ny + gj] = True
    if not np.any(finite.ravel() & ~always):
        return relaxed
    out: Array = np.where(finite, roomy, relaxed + float(np.max(roomy[finite], initial=0.0)))
    return out


def _in_reach(
    grid: LatticeGrid, at_centres: Array, goal: tuple[float, float], free: float
) -> NDArray[np.bool_]:
    """The cells within ``free`` of the goal whose straight way to it keeps a unit's radius
    clear: from there the body reaches the goal with its head. (Without the way test, the map
    leaked through thin walls: a cell behind a wall next to the goal looked almost there.)"""
    centres, r = grid.centres, grid.settings.resolution
    near = cells_within(grid, goal, free)
    out = np.zeros(len(centres), dtype=bool)
    if near.size == 0:
        return out
    t = np.linspace(0.0, 1.0, max(2, math.ceil(free / (r / 2)) + 1))
    way = centres[near, None, :] + t[None, :, None] * (np.asarray(goal) - centres[near, None, :])
    i = np.clip(((way[..., 0] - grid.bounds.xmin) / r).astype(int), 0, grid.nx - 1)
    j = np.clip(((way[..., 1] - grid.bounds.ymin) / r).astype(int), 0, grid.ny - 1)
    clear = at_centres[i * grid.ny + j].min(axis=1)
    out[near] = clear >= DEFAULT_GEOMETRY.unit_radius - r * math.sqrt(0.5)
    return out


def cells_within(grid: LatticeGrid, point: tuple[float, float], radius: float) -> NDArray[np.intp]:
    """The rows of ``grid.centres`` within ``radius`` of ``point``, ascending (looked for only
    in the box of cells around it, not over the whole grid)."""
    centres = grid.centres.reshape(grid.nx, grid.ny, 2)
    i, j, distance = cells_round(centres[:, 0, 0], centres[0, :, 1], point, radius)
    out: NDArray[np.intp] = (i * grid.ny + j)[distance <= radius]
    return out


def window_distance_map(
    grid: LatticeGrid,
    window: tuple[slice, slice],
    at_window: Array,
    targets: Sequence[tuple[int, int]],
    need: float,
    start: tuple[int, int] | None = None,
) -> Array:
    """``distance_map`` within a window of cells (``at_window``: the clearance at its cell
    centres, ``[wi * wj]`` in row order) to the nearest of the cells ``targets`` (grid
    indices): what a local repair needs, at a cost that depends on the window, not on the
    arena."""
    wi, wj = window
    shape = (wi.stop - wi.start, wj.stop - wj.start)
    r = grid.settings.resolution
    ok = (at_window >= need - r * math.sqrt(0.5)).reshape(shape)
    local = [(i - wi.start, j - wj.start) for i, j in targets]
    for i, j in local:
        ok[i, j] = True
    if start is not None:
        i, j = np.indices(shape)
        ok |= np.hypot(i + wi.start - start[0], j + wj.start - start[1]) * r <= START_FREE
    return geodesic(ok, local, r)


def geodesic(ok: NDArray[np.bool_], sources: Sequence[tuple[int, int]], r: float) -> Array:
    """Dijkstra distances (m) from the nearest of the cells ``sources`` over the 8-connected cells where ``ok``
    (``[nx, ny]``; ``inf`` where cut off)."""
    nx, ny = ok.shape
    index = [i * ny + j for i, j in sources]
    if lattice_kernels.AVAILABLE:
        return lattice_kernels.grid_dijkstra(ok, np.array(index, dtype=np.int64), r)
    flat = ok.ravel()
    graph, rows = _topology(nx, ny, r)
    # The 8-connected graph is built once per grid; edges into or out of blocked cells get an
    # infinite weight (Dijkstra never improves a distance over them).
    blocked = ~(flat[rows] & flat[graph.indices])
    weighted = csr_matrix(
        (np.where(blocked, np.inf, graph.data), graph.indices, graph.indptr), shape=graph.shape
    )
    dist = dijkstra(weighted, directed=True, indices=index, min_only=True)
    return np.asarray(dist, dtype=float).reshape(nx, ny)


@lru_cache(maxsize=8)
def _topology(nx: int, ny: int, r: float) -> tuple[csr_matrix, NDArray[np.intp]]:
    """Every 8-neighbour edge of an ``nx × ny`` grid with its length, and each edge's source."""
    index = np.arange(nx * ny).reshape(nx, ny)
    rows, cols, weights = [], [], []
    for di, dj in NEIGHBOURS:
        ia = index[max(0, -di) : nx - max(0, di), max(0, -dj) : ny - max(0, dj)].ravel()
        ib = index[max(0, di) : nx - max(0, -di), max(0, dj) : ny - max(0, -dj)].ravel()
        rows.append(ia)
        cols.append(ib)
        weights.append(np.full(ia.size, r * math.hypot(di, dj)))
    graph = coo_matrix(
        (np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))),
        shape=(nx * ny, nx * ny),
    ).tocsr()
    sources = np.repeat(np.arange(nx * ny), np.diff(graph.indptr))
    return graph, sources

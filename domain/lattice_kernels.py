"""Compiled (numba) kernels of the lattice planner: the 8-connected grid Dijkstra, and which
motions of a state keep their clearance.

scipy's csgraph Dijkstra needs the grid as a sparse matrix whose edge weights are rebuilt for
every map (infinite into blocked cells), a few passes over eight edges per cell in numpy before
the search starts; on a 20 m arena (160,000 cells) that is most of a distance map's cost. The
kernel searches the grid directly with a bucket queue. A cell's distance is the least
``dist[u] + w`` over its neighbours nearer the sources, each sum the same float operation as
scipy's, so the maps are the same value for value (``tests/domain/test_lattice_kernels.py`` holds it to
scipy's). Without numba (or with ``SCREWSNAKE_KERNELS=numpy``) ``AVAILABLE`` is False and the
planner uses scipy.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from domain.occupancy_kernel import AVAILABLE, _jit
from sim.robot import Array

__all__ = ["AVAILABLE", "grid_dijkstra", "motions_free"]


def motions_free(
    clear: Array, inverse: NDArray[np.intp], need: Array, segments: NDArray[np.int64]
) -> NDArray[np.bool_]:
    """Per motion: whether every one of its sample points keeps its need, from the clearance
    at a bin's distinct points (``clear``), each sample's row among them (``inverse``), its
    need (``need``) and where each motion's samples start (``segments``)."""
    if AVAILABLE:
        out = np.empty(len(segments), dtype=np.bool_)
        _motions_free(clear, inverse, need, segments, out)
        return out
    free: NDArray[np.bool_] = np.logical_and.reduceat(clear[inverse] >= need, segments)
    return free


def grid_dijkstra(ok: NDArray[np.bool_], sources: NDArray[np.int64], r: float) -> Array:
    """Distances (m) from the nearest of the cells ``sources`` (flat indices) over the
    8-connected cells of ``ok`` ``[nx, ny]`` (edges of length ``r`` and ``r·√2`` between cells
    that are both ok; ``inf`` where cut off)."""
    nx, ny = ok.shape
    dist = np.full(nx * ny, np.inf)
    _dijkstra(np.ascontiguousarray(ok).ravel(), nx, ny, sources, r, r * math.hypot(1, 1), dist)
    return dist.reshape(nx, ny)


@_jit
def _dijkstra(  # pragma: no cover - compiled
    ok: NDArray[np.bool_],
    nx: int,
    ny: int,
    sources: NDArray[np.int64],
    axial: float,
    diagonal: float,
    dist: Array,
) -> None:
    """Dijkstra from ``sources`` into ``dist`` (filled with inf) with a bucket queue (Dial's):
    buckets a little narrower than the shortest edge, so no two cells of one bucket can improve
    each other and a bucket's cells are final in any order; with edges at most ``√2`` of the
    shortest, only three buckets are ever live (a ring of four). A cell lowered within the
    bucket it is queued in keeps its one entry there (several sources lower a cell beside
    them twice, diagonally then straight), so no bucket holds more than the ``n`` cells."""
    n = nx * ny
    width = axial * (1.0 - 1e-9)
    ring = 4
    buckets = np.empty((ring, n), dtype=np.int64)  # cell numbers, possibly stale entries
    sizes = np.zeros(ring, dtype=np.int64)
    done = np.zeros(n, dtype=np.bool_)
    for s in sources:
        if dist[s] == 0.0:
            continue
        dist[s] = 0.0
        buckets[0, sizes[0]] = s
        sizes[0] += 1
    di = (1, -1, 0, 0, 1, 1, -1, -1)
    dj = (0, 0, 1, -1, 1, -1, 1, -1)
    current = 0
    live = sizes[0]
    while live > 0:
        b = current % ring
        while sizes[b] > 0:
            sizes[b] -= 1
            live -= 1
            u = buckets[b, sizes[b]]
            if done[u] or int(dist[u] / width) != current:
                continue  # settled already, or moved to an earlier bucket since
            done[u] = True
            if not ok[u]:
                continue  # a blocked source: nothing leaves it
            ui, uj = u // ny, u % ny
            du = dist[u]
            for e in range(8):
                vi, vj = ui + di[e], uj + dj[e]
                if vi < 0 or vi >= nx or vj < 0 or vj >= ny:
                    continue
                v = vi * ny + vj
                if done[v] or not ok[v]:
                    continue
                nd = du + (axial if e < 4 else diagonal)
                if nd < dist[v]:
                    t = int(nd / width)
                    queued = dist[v] < np.inf and int(dist[v] / width) == t
                    dist[v] = nd
                    if queued:
                        continue  # its entry in that bucket reads the new distance
                    t %= ring
                    buckets[t, sizes[t]] = v
                    sizes[t] += 1
                    live += 1
        current += 1


@_jit
def _motions_free(  # pragma: no cover - compiled
    clear: Array,
    inverse: NDArray[np.intp],
    need: Array,
    segments: NDArray[np.int64],
    out: NDArray[np.bool_],
) -> None:
    """``motions_free`` in one loop, each motion's points until the first that fails."""
    m_count = segments.shape[0]
    for m in range(m_count):
        end = segments[m + 1] if m + 1 < m_count else inverse.shape[0]
        ok = True
        for p in range(segments[m], end):
            if not clear[inverse[p]] >= need[p]:
                ok = False
                break
        out[m] = ok

"""Compiled (numba) kernels of the lattice planner: the 8-connected grid Dijkstra.

scipy's csgraph Dijkstra needs the grid as a sparse matrix whose edge weights are rebuilt for
every map (infinite into blocked cells), a few passes over eight edges per cell in numpy before
the search starts; on a 20 m arena (160,000 cells) that is most of a distance map's cost. The
kernel searches the grid directly with an indexed binary heap. A cell's distance is the least
``dist[u] + w`` over its settled neighbours, each sum the same float operation as scipy's, so
the maps are the same value for value (``tests/domain/test_lattice_kernels.py`` holds it to
scipy's). Without numba (or with ``SCREWSNAKE_KERNELS=numpy``) ``AVAILABLE`` is False and the
planner uses scipy.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from domain.occupancy_kernel import AVAILABLE, _jit
from sim.robot import Array

__all__ = ["AVAILABLE", "grid_dijkstra"]


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
    """Dijkstra from ``sources`` into ``dist`` (filled with inf) with an indexed binary heap."""
    n = nx * ny
    heap = np.empty(n, dtype=np.int64)  # cell numbers, ordered by dist
    pos = np.full(n, -1, dtype=np.int64)  # where a cell sits in the heap (-1: not in it)
    done = np.zeros(n, dtype=np.bool_)
    size = 0
    for s in sources:
        if dist[s] == 0.0:
            continue
        dist[s] = 0.0
        heap[size] = s
        pos[s] = size
        size += 1
    di = (1, -1, 0, 0, 1, 1, -1, -1)
    dj = (0, 0, 1, -1, 1, -1, 1, -1)
    while size > 0:
        u = heap[0]
        size -= 1
        pos[u] = -1
        done[u] = True
        if size > 0:  # the last entry to the root, sifted down
            last = heap[size]
            k = 0
            while True:
                c = 2 * k + 1
                if c >= size:
                    break
                if c + 1 < size and dist[heap[c + 1]] < dist[heap[c]]:
                    c += 1
                if dist[heap[c]] < dist[last]:
                    heap[k] = heap[c]
                    pos[heap[k]] = k
                    k = c
                else:
                    break
            heap[k] = last
            pos[last] = k
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
                dist[v] = nd
                k = pos[v]
                if k < 0:
                    k = size
                    size += 1
                while k > 0:  # sift up
                    p = (k - 1) // 2
                    if dist[heap[p]] <= nd:
                        break
                    heap[k] = heap[p]
                    pos[heap[k]] = k
                    k = p
                heap[k] = v
                pos[v] = k

"""The compiled check of which motions of a lattice state keep their clearance, as a bitmask.

``LatticeTask.free_mask`` for the compiled search (domain/lattice_search_kernel.py): the swept
sample points of each motion against the clearance's grids (domain/grid_clearance.py), with
``interpolate._compiled``'s arithmetic written out in the loop (the same operations, so the same
verdicts), each motion stopping at its first point that fails.
"""

from __future__ import annotations

import math

from domain.grid_clearance import clearance_at
from domain.occupancy_kernel import _jit
from sim.robot import Array


@_jit
def _samples_clear(  # pragma: no cover - compiled
    flat: Array,
    gnx: int,
    gny: int,
    geo: Array,
    cx: float,
    cy: float,
    ux: Array,
    uy: Array,
    inverse: Array,
    needs: Array,
    lo: int,
    hi: int,
) -> bool:
    """Whether samples ``lo:hi`` keep their needs, with the clearance of one grid
    (``grid_clearance.bilinear_at`` written out: the same operations, constants hoisted)."""
    ox, oy, res = geo[0], geo[1], geo[2]
    xmin, xmax, ymin, ymax = geo[3], geo[4], geo[5], geo[6]
    top_u, top_v = gnx - 1.0, gny - 1.0
    i_top, j_top = max(gnx - 2, 0), max(gny - 2, 0)
    di = gny if gnx > 1 else 0
    dj = 1 if gny > 1 else 0
    for p in range(lo, hi):
        q = inverse[p]
        x, y = cx + ux[q], cy + uy[q]
        u = min(max((x - ox) / res - 0.5, 0.0), top_u)
        v = min(max((y - oy) / res - 0.5, 0.0), top_v)
        i0 = min(int(u), i_top)
        j0 = min(int(v), j_top)
        fu, fv = u - i0, v - j0
        base = i0 * gny + j0
        low = flat[base] * (1 - fv) + flat[base + dj] * fv
        high = flat[base + di] * (1 - fv) + flat[base + di + dj] * fv
        wall = min(min(x - xmin, xmax - x), min(y - ymin, ymax - y))
        if not min(low * (1 - fu) + high * fu, wall) >= needs[p]:
            return False
    return True


@_jit
def _samples_clear_mixed(  # pragma: no cover - compiled
    flat: Array,
    flat_near: Array,
    gny: int,
    goals: Array,
    geo: Array,
    cx: float,
    cy: float,
    ux: Array,
    uy: Array,
    inverse: Array,
    needs: Array,
    lo: int,
    hi: int,
) -> bool:
    """``_samples_clear`` for the ``off-goals`` clearance (the second grid near a goal)."""
    gnx = flat.shape[0] // gny
    ox, oy, res = geo[0], geo[1], geo[2]
    xmin, xmax, ymin, ymax, radius = geo[3], geo[4], geo[5], geo[6], geo[7]
    top_u, top_v = gnx - 1.0, gny - 1.0
    i_top, j_top = max(gnx - 2, 0), max(gny - 2, 0)
    di = gny if gnx > 1 else 0
    dj = 1 if gny > 1 else 0
    for p in range(lo, hi):
        q = inverse[p]
        x, y = cx + ux[q], cy + uy[q]
        grid = flat
        for g in range(goals.shape[0]):
            gx, gy = x - goals[g, 0], y - goals[g, 1]
            if math.sqrt(gx * gx + gy * gy) < radius:
                grid = flat_near
                break
        u = min(max((x - ox) / res - 0.5, 0.0), top_u)
        v = min(max((y - oy) / res - 0.5, 0.0), top_v)
        i0 = min(int(u), i_top)
        j0 = min(int(v), j_top)
        fu, fv = u - i0, v - j0
        base = i0 * gny + j0
        low = grid[base] * (1 - fv) + grid[base + dj] * fv
        high = grid[base + di] * (1 - fv) + grid[base + di + dj] * fv
        wall = min(min(x - xmin, xmax - x), min(y - ymin, ymax - y))
        if not min(low * (1 - fu) + high * fu, wall) >= needs[p]:
            return False
    return True


@_jit
def free_bits(  # pragma: no cover - compiled
    number: int,
    dims: Array,
    gf: Array,
    at_centres: Array,
    values: Array,
    near: Array,
    goals: Array,
    geo: Array,
    ux: Array,
    uy: Array,
    inverse: Array,
    needs: Array,
    segments: Array,
    deltas: Array,
    cell_reach: Array,
) -> int:
    """``LatticeTask.free_mask`` of a state (not the start) as a bitmask: the motions whose
    swept sample points all keep their need (with the margin), and which end on the grid.
    ``gf``: grid xmin, ymin, resolution, open clearance + margin."""
    nx, ny = dims[0], dims[1]
    plane = nx * ny
    k, cell = number // plane, number % plane
    i, j = cell // ny, cell % ny
    cx = gf[0] + (i + 0.5) * gf[2]
    cy = gf[1] + (j + 0.5) * gf[2]
    if at_centres.shape[0] > 0:
        here = at_centres[cell]
    else:
        here = clearance_at(values, near, goals, geo, cx, cy)
    n_motions = segments.shape[1] - 1
    bits = 0
    if here >= gf[3]:
        bits = (1 << n_motions) - 1  # open space: nothing near enough
    else:
        flat, flat_near = values.ravel(), near.ravel()
        for m in range(n_motions):
            lo, hi = segments[k, m], segments[k, m + 1]
            if near.shape[0] > 0:
                ok = _samples_clear_mixed(
                    flat,
                    flat_near,
                    values.shape[1],
                    goals,
                    geo,
                    cx,
                    cy,
                    ux[k],
                    uy[k],
                    inverse[k],
                    needs[k],
                    lo,
                    hi,
                )
            else:
                ok = _samples_clear(
                    flat,
                    values.shape[0],
                    values.shape[1],
                    geo,
                    cx,
                    cy,
                    ux[k],
                    uy[k],
                    inverse[k],
                    needs[k],
                    lo,
                    hi,
                )
            if ok:
                bits |= 1 << m
    reach = cell_reach[k]
    if not (reach <= i < nx - reach and reach <= j < ny - reach):
        for m in range(n_motions):
            ni, nj = i + deltas[k, m, 0], j + deltas[k, m, 1]
            if not (0 <= ni < nx and 0 <= nj < ny):
                bits &= ~(1 << m)
    return bits

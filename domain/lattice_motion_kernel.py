"""The compiled check of which motions of a lattice state keep their clearance, as a bitmask.

``LatticeTask.free_mask`` for the compiled search (domain/lattice_search_kernel.py): the swept
sample points of each motion against the clearance's grids (domain/grid_clearance.py), with
``interpolate._compiled``'s arithmetic written out in the loop (the same operations, so the same
verdicts): the clearance at each distinct point of the bin once, then each motion's points in
turn until the first that fails.
"""

from __future__ import annotations

from domain.grid_clearance import bilinear_at
from domain.occupancy_kernel import _jit
from sim.robot import Array


@_jit
def _distinct_clearance(  # pragma: no cover - compiled
    values: Array,
    geo: Array,
    cx: float,
    cy: float,
    ux: Array,
    uy: Array,
    count: int,
    out: Array,
    su: Array,
    sv: Array,
) -> None:
    """The clearance at a bin's first ``count`` distinct sample points about ``(cx, cy)`` into
    ``out``: ``grid_clearance.clearance_at`` written out (the same operations), every distinct
    point once as ``LatticeTask._free_motions`` does. The divisions in a first loop of their
    own (``su``, ``sv``: room for the grid coordinates), which the compiler vectorises, the
    grid reads in a second."""
    gnx, gny = values.shape
    flat = values.ravel()
    ox, oy, res = geo[0], geo[1], geo[2]
    xmin, xmax, ymin, ymax = geo[3], geo[4], geo[5], geo[6]
    top_u, top_v = gnx - 1.0, gny - 1.0
    i_top, j_top = max(gnx - 2, 0), max(gny - 2, 0)
    di = gny if gnx > 1 else 0
    dj = 1 if gny > 1 else 0
    for q in range(count):
        x, y = cx + ux[q], cy + uy[q]
        su[q] = min(max((x - ox) / res - 0.5, 0.0), top_u)
        sv[q] = min(max((y - oy) / res - 0.5, 0.0), top_v)
        out[q] = min(min(x - xmin, xmax - x), min(y - ymin, ymax - y))  # the walls
    for q in range(count):
        u, v = su[q], sv[q]
        i0 = min(int(u), i_top)
        j0 = min(int(v), j_top)
        fu, fv = u - i0, v - j0
        base = i0 * gny + j0
        low = flat[base] * (1 - fv) + flat[base + dj] * fv
        high = flat[base + di] * (1 - fv) + flat[base + di + dj] * fv
        out[q] = min(low * (1 - fu) + high * fu, out[q])


@_jit
def free_bits(  # pragma: no cover - compiled
    number: int,
    dims: Array,
    gf: Array,
    at_centres: Array,
    values: Array,
    geo: Array,
    ux: Array,
    uy: Array,
    inverse: Array,
    needs: Array,
    segments: Array,
    deltas: Array,
    cell_reach: Array,
    n_unique: Array,
    scratch: Array,
) -> int:
    """``LatticeTask.free_mask`` of a state (not the start) as a bitmask: the motions whose
    swept sample points all keep their need (with the margin), and which end on the grid.
    ``gf``: grid xmin, ymin, resolution, open clearance + margin; ``n_unique``: each bin's
    distinct points; ``scratch`` ``[3, U]``: room for the clearance at as many."""
    nx, ny = dims[0], dims[1]
    plane = nx * ny
    k, cell = number // plane, number % plane
    i, j = cell // ny, cell % ny
    cx = gf[0] + (i + 0.5) * gf[2]
    cy = gf[1] + (j + 0.5) * gf[2]
    here = at_centres[cell] if at_centres.shape[0] > 0 else bilinear_at(values, geo, cx, cy)
    n_motions = segments.shape[1] - 1
    bits = 0
    if here >= gf[3]:
        bits = (1 << n_motions) - 1  # open space: nothing near enough
    else:
        n = n_unique[k]
        _distinct_clearance(
            values, geo, cx, cy, ux[k], uy[k], n, scratch[0], scratch[1], scratch[2]
        )
        clear = scratch[0]
        for m in range(n_motions):
            ok = True
            for p in range(segments[k, m], segments[k, m + 1]):
                if not clear[inverse[k, p]] >= needs[k, p]:
                    ok = False
                    break
            if ok:
                bits |= 1 << m
    reach = cell_reach[k]
    if not (reach <= i < nx - reach and reach <= j < ny - reach):
        for m in range(n_motions):
            ni, nj = i + deltas[k, m, 0], j + deltas[k, m, 1]
            if not (0 <= ni < nx and 0 <= nj < ny):
                bits &= ~(1 << m)
    return bits

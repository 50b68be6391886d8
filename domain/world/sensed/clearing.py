"""Compiled (numba) kernels of the sensed layer's clearing half: readings laid out, beams swept.

``SensedLayer.integrate`` in numpy is a few dozen calls on a few hundred cells per tick, most
of a tick's cost. These kernels (with ``marking``'s, the marking half: hit
evidence shared and applied) do the same update in compiled loops and give the same
numbers, value for value: every float is computed by the same operations in the same order
(no fast-math, so no fused multiply-adds), the range likelihoods are summed in sample order as
``np.bincount`` sums them, and a hit's evidence is normalised by numpy's pairwise summation
(``_pairwise_sum``). The transcendental functions stay in numpy (the ray directions' cos/sin and
the occupancy probabilities' exp): numpy's SIMD versions may round differently from LLVM's.
``tests/domain/test_occupancy_kernel.py`` holds the kernels to the numpy path. Without numba
(or with ``SCREWSNAKE_KERNELS=numpy``) the layer takes its numpy path (``domain.kernels``).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from domain.kernels import AVAILABLE, jit
from sim.robot import Array

__all__ = ["AVAILABLE", "Ints", "free_cells", "layout", "sweep_and_clear"]

Ints = NDArray[np.int64]


@jit
def _pairwise_sum(a: Array, lo: int, n: int) -> float:  # pragma: no cover - compiled
    """``np.sum(a[lo:lo + n])`` with numpy's own pairwise order (8 accumulators per block of 128)."""
    if n < 8:
        res = 0.0
        for i in range(n):
            res += a[lo + i]
        return res
    if n <= 128:
        r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
        r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
        i = 8
        while i < n - (n % 8):
            r0 += a[lo + i]
            r1 += a[lo + i + 1]
            r2 += a[lo + i + 2]
            r3 += a[lo + i + 3]
            r4 += a[lo + i + 4]
            r5 += a[lo + i + 5]
            r6 += a[lo + i + 6]
            r7 += a[lo + i + 7]
            i += 8
        res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
        while i < n:
            res += a[lo + i]
            i += 1
        return float(res)
    n2 = n // 2
    n2 -= n2 % 8
    return float(_pairwise_sum(a, lo, n2) + _pairwise_sum(a, lo + n2, n - n2))


@jit
def _cell(x: float, y: float, ox: float, oy: float, res: float, nx: int, ny: int) -> int:
    """Flat index of the cell holding (x, y) as ``Grid.locate`` finds it; -1 off the grid."""
    i = int(np.floor((x - ox) / res))
    j = int(np.floor((y - oy) / res))
    if i < 0 or i >= nx or j < 0 or j >= ny:
        return -1
    return i * ny + j


@jit
def free_cells(  # pragma: no cover - compiled
    log_odds: Array, occupied: NDArray[np.bool_], cells: Ints, floor: float
) -> Ints:
    """``SensedLayer.free`` in one call: ``cells`` (flat, distinct) go to the ``floor``; the
    ones that were occupied (in ``cells``' order) stop being so and are returned."""
    out = np.empty(cells.size, dtype=np.int64)
    n = 0
    for c in cells:
        log_odds[c] = floor
        if occupied[c]:
            occupied[c] = False
            out[n] = c
            n += 1
    return out[:n]


@jit
def sweep_and_clear(  # pragma: no cover - compiled
    log_odds: Array,
    grid: Array,  # (ox, oy, res)
    shape: Ints,  # (nx, ny)
    cos: Array,  # the beams' sweep directions
    sin: Array,
    arc_cos: Array,  # the hits' arc directions
    arc_sin: Array,
    beams: Array,  # [K, 2]: origin x, y of every valid reading
    swept: Ints,  # [K, 3]: first direction, directions, ranges (0: the beam clears nothing)
    sweep_step: float,
    hits: Ints,  # [H, 4]: reading, first direction, directions, range samples
    hit_range: Array,  # [H, 3]: measured range, noise σ, first z index
    z_all: Array,
    w_all: Array,
    log_odds_free: float,
    log_odds_min: float,
    mark: Ints,  # scratch, one per cell, all -1 between calls
    acc: Array,  # scratch, one per cell, all 0 between calls
) -> tuple[Ints, Array, Ints, Ints]:
    """The clearing half: find each hit's arc cells (sorted, with summed likelihoods), then clear
    every cell each beam swept (once per beam, not the beam's own arc cells) by
    ``log_odds_free`` per beam, clamped at ``log_odds_min``.

    Returns the arc cells of all hits concatenated, their likelihoods, each hit's first arc
    cell (``[H + 1]`` bounds), and the cleared cells (distinct, in the order found).
    """
    ox, oy, res = grid[0], grid[1], grid[2]
    nx, ny = shape[0], shape[1]
    n_hits = hits.shape[0]
    total = 0
    for h in range(n_hits):
        total += hits[h, 2] * hits[h, 3]
    arc = np.empty(total, dtype=np.int64)
    lik = np.empty(total, dtype=np.float64)
    bounds = np.zeros(n_hits + 1, dtype=np.int64)
    n_arc = 0
    for h in range(n_hits):
        start = n_arc
        d0, nd, nz = hits[h, 1], hits[h, 2], hits[h, 3]
        x0, y0 = beams[hits[h, 0], 0], beams[hits[h, 0], 1]
        dist, sigma, z0 = hit_range[h, 0], hit_range[h, 1], int(hit_range[h, 2])
        for zi in range(nz):
            rho = max(dist + sigma * z_all[z0 + zi], 0.0)
            w = w_all[z0 + zi]
            for di in range(nd):
                c = _cell(
                    x0 + rho * arc_cos[d0 + di], y0 + rho * arc_sin[d0 + di], ox, oy, res, nx, ny
                )
                if c < 0:
                    continue
                if mark[c] != h:
                    mark[c] = h
                    arc[n_arc] = c
                    n_arc += 1
                    acc[c] = 0.0 + w  # as bincount: sums start at zero
                else:
                    acc[c] += w
        arc[start:n_arc] = np.sort(arc[start:n_arc])
        for m in range(start, n_arc):
            lik[m] = acc[arc[m]]
            acc[arc[m]] = 0.0
            mark[arc[m]] = -1
        bounds[h + 1] = n_arc
    # Clearing: each beam sweeps its cells once; its own arc cells are not cleared by it.
    n_beams = beams.shape[0]
    samples = 0
    for k in range(n_beams):
        samples += swept[k, 1] * swept[k, 2]
    cleared = np.empty(samples, dtype=np.int64)
    n_cleared = 0
    counts = np.empty(samples, dtype=np.int64)
    hit_of = np.full(n_beams, -1, dtype=np.int64)
    for h in range(n_hits):
        hit_of[hits[h, 0]] = h
    own = n_hits  # marks above the hit indices: this beam's own arc cells
    for k in range(n_beams):
        h = hit_of[k]
        if h >= 0:
            for m in range(bounds[h], bounds[h + 1]):
                mark[arc[m]] = own + 2 * k
        seen = own + 2 * k + 1
        d0, nd, nr = swept[k, 0], swept[k, 1], swept[k, 2]
        x0, y0 = beams[k, 0], beams[k, 1]
        for ri in range(nr):
            rho = ri * sweep_step
            for di in range(nd):
                c = _cell(x0 + rho * cos[d0 + di], y0 + rho * sin[d0 + di], ox, oy, res, nx, ny)
                if c < 0 or mark[c] == seen or mark[c] == own + 2 * k:
                    continue
                mark[c] = seen
                if acc[c] == 0.0:
                    cleared[n_cleared] = c
                    n_cleared += 1
                acc[c] += 1.0  # a count, exact in floating point
    cells = cleared[:n_cleared]  # each cell once, in the order found (updates are per cell)
    for m in range(n_cleared):
        c = cells[m]
        counts[m] = int(acc[c])
        acc[c] = 0.0
    for k in range(n_beams):  # forget the marks: they are set only on swept and arc cells
        h = hit_of[k]
        if h >= 0:
            for m in range(bounds[h], bounds[h + 1]):
                mark[arc[m]] = -1
    for m in range(n_cleared):
        mark[cells[m]] = -1
    for m in range(n_cleared):
        c = cells[m]
        log_odds[c] = max(log_odds[c] + counts[m] * log_odds_free, log_odds_min)
    return arc[:n_arc], lik[:n_arc], bounds, cells


@jit
def _spread(fov: float, n: int, i: int) -> float:  # pragma: no cover - compiled
    """``np.linspace(-fov / 2, fov / 2, n)[i]`` as numpy computes it (``i * step + start``,
    the last one ``stop`` itself; ``beams.spread``)."""
    start, stop = -fov / 2, fov / 2
    if i == n - 1:
        return stop
    delta = stop - start
    step = delta / (n - 1)
    if step == 0:
        return float(i) / (n - 1) * delta + start
    return float(i) * step + start


@jit
def layout(  # pragma: no cover - compiled
    rows: Array,  # [K, 8]: origin x, y, angle, fov, max range, distance, hit (0/1), noise σ
    step: float,  # beam sample spacing (m)
    clear_sigmas: float,
    clear_margin: float,
    explained_sigmas: float,
    resolution: float,
    unambiguous_arc: float,
    table_z: Array,  # likelihoods(n) for n = 1..: z values ...
    table_w: Array,  # ... and weights, one after the other
    table_first: Ints,  # where likelihoods(n) starts in them, [N + 2]
) -> tuple[Array, Array, Array, Ints, Ints, Array, Array, Array, Array, NDArray[np.bool_], int]:
    """The per-reading bookkeeping of ``SensedLayer._integrate_compiled``: every valid
    reading's sweep directions (angles) and range samples, every hit's arc directions, range
    likelihoods, explained tolerance and whether its arc is narrow, with the same arithmetic as
    the Python loop it replaces. The last value is the largest likelihood sample count needed:
    when it exceeds the table, nothing else is filled and the caller extends the table."""
    k_all = rows.shape[0]
    half = step / 2
    need = 0
    n_sweep = 0
    n_arc = 0
    n_hits = 0
    n_z_total = 0
    for k in range(k_all):
        fov, reach = rows[k, 3], min(rows[k, 5], rows[k, 4])
        until = reach - (clear_sigmas * rows[k, 7] + clear_margin)
        if until > 0:
            n_sweep += 1 if fov == 0 else math.ceil(fov * until / step) + 1
        if rows[k, 6] != 0:
            n_z = 2 * math.ceil(2.0 * rows[k, 7] / half) + 1
            need = max(need, n_z)
            n_arc += 1 if fov == 0 else math.ceil(fov * reach / half) + 1
            n_hits += 1
            n_z_total += n_z
    sweep = np.empty(n_sweep)
    arc = np.empty(n_arc)
    beams = np.empty((k_all, 2))
    swept = np.zeros((k_all, 3), dtype=np.int64)
    hits = np.empty((n_hits, 4), dtype=np.int64)
    hit_range = np.empty((n_hits, 3))
    z_all = np.empty(n_z_total)
    w_all = np.empty(n_z_total)
    tolerance = np.empty(n_hits)
    narrow = np.empty(n_hits, dtype=np.bool_)
    if need >= table_first.size - 1:
        return sweep, arc, beams, swept, hits, hit_range, z_all, w_all, tolerance, narrow, need
    n_sweep = n_arc = h = z_count = 0
    for k in range(k_all):
        angle, fov, noise = rows[k, 2], rows[k, 3], rows[k, 7]
        reach = min(rows[k, 5], rows[k, 4])
        beams[k, 0], beams[k, 1] = rows[k, 0], rows[k, 1]
        until = reach - (clear_sigmas * noise + clear_margin)
        if until > 0:  # as beams.swept_cells and beams._fan sample it
            n = 1 if fov == 0 else math.ceil(fov * until / step) + 1
            swept[k, 0], swept[k, 1] = n_sweep, n
            swept[k, 2] = math.ceil(until / step)
            for i in range(n):
                sweep[n_sweep + i] = angle + _spread(fov, n, i) if n > 1 else angle
            n_sweep += n
        if rows[k, 6] != 0:  # as beams.arc_cells samples it
            n_z = 2 * math.ceil(2.0 * noise / half) + 1
            n = 1 if fov == 0 else math.ceil(fov * reach / half) + 1
            hits[h, 0], hits[h, 1], hits[h, 2], hits[h, 3] = k, n_arc, n, n_z
            hit_range[h, 0], hit_range[h, 1], hit_range[h, 2] = reach, noise, z_count
            for i in range(n):
                arc[n_arc + i] = angle + _spread(fov, n, i) if n > 1 else angle
            n_arc += n
            first = table_first[n_z]
            for i in range(n_z):
                z_all[z_count + i] = table_z[first + i]
                w_all[z_count + i] = table_w[first + i]
            z_count += n_z
            tolerance[h] = explained_sigmas * noise + resolution * math.sqrt(0.5)
            narrow[h] = fov * reach <= unambiguous_arc * resolution
            h += 1
    return sweep, arc, beams, swept, hits, hit_range, z_all, w_all, tolerance, narrow, need

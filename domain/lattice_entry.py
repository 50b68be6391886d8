"""Whether any free lattice motion ends on a goal: without one, no search of the leg can reach it.

A leg's plan ends with a goal visit from a state where the head is on the goal (a *near*
state), and the search reaches a state only by a free motion from another (or starts there).
So when no near state is the start and no motion from a state that is not near into one that
is is free (the first near state met is entered so), the goal cannot
be reached on this lattice, however long a search runs. The reachability test
(domain/lattice_reach.py) relaxes the body to resting configurations and cannot see this: a
goal beside a bar may have room for the resting body round it, yet every motion that would
bring the head there sweeps the bar. A search then spends its whole budget (tens of
thousands of expansions) before it gives up; this test asks a few thousand motions once.

A motion is free here exactly as in the search: the same sample points and needs, the same
clearance arithmetic (``grid_clearance.bilinear_at``), the open-space shortcut, the start's
own allowance for motions that leave the start.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from domain.grid_clearance import bilinear_at, grids_of
from domain.lattice_search import kernel_table, state_inputs
from domain.lattice_task import LatticeTask
from domain.occupancy_kernel import AVAILABLE, _jit
from sim.robot import Array


def goal_entered(task: LatticeTask) -> bool:
    """Whether the leg's start is on its goal or some free motion ends on it (``False``: no
    search of this task can reach the goal; see the module's docstring)."""
    near = task.near_states()
    if near.size == 0:
        return False
    if task.start_number in near:
        return True
    grid, table = task.grid, task.table
    K, nx, ny = grid.settings.orientations, grid.nx, grid.ny
    start_bits = np.flatnonzero(task.free_mask(task.start_key)).astype(np.int64)
    grids = grids_of(task.clearance)
    if AVAILABLE and grids is not None:
        kt = kernel_table(table, task.margin)
        gf, at_centres = state_inputs(task, kt)
        return bool(
            _entered(
                near, task.start_number, start_bits, np.array([nx, ny, K], dtype=np.int64),
                gf, at_centres, grids.values, grids.geometry, kt.ux, kt.uy, kt.inverse,
                kt.needs, kt.segments, kt.deltas,
            )
        )  # fmt: skip
    for pred, motion in _entries(near, table.deltas, K, nx, ny):
        key = grid.decode(pred)
        if task.free_mask(key)[motion]:
            return True
    return False


def _entries(
    near: NDArray[np.int64], deltas: NDArray[np.int64], K: int, nx: int, ny: int
) -> list[tuple[int, int]]:
    """Every (state, motion) whose motion ends on a near state from a state on the grid
    that is not near."""
    plane = nx * ny
    out = []
    is_near = set(near.tolist())
    for n in near.tolist():
        kn, cell = divmod(n, plane)
        i, j = divmod(cell, ny)
        for kp in range(K):
            for m in range(deltas.shape[1]):
                di, dj, dk = (int(v) for v in deltas[kp, m])
                if (kp + dk) % K != kn:
                    continue
                pi, pj = i - di, j - dj
                pred = (kp * nx + pi) * ny + pj
                if 0 <= pi < nx and 0 <= pj < ny and pred not in is_near:
                    out.append((pred, m))
    return out


@_jit
def _entered(  # pragma: no cover - compiled
    near: NDArray[np.int64],
    start: int,
    start_bits: NDArray[np.int64],
    dims: NDArray[np.int64],
    gf: Array,
    at_centres: Array,
    values: Array,
    geo: Array,
    ux: Array,
    uy: Array,
    inverse: NDArray[np.int64],
    needs: Array,
    segments: NDArray[np.int64],
    deltas: NDArray[np.int64],
) -> bool:
    """``goal_entered``'s loop: for each near state (``near``, sorted), each motion of each
    bin that ends there from a state on the grid that is not near, that motion's points
    against their needs (the first free one answers). ``start_bits``: the start's free
    motions (its own allowance)."""
    nx, ny, K = dims[0], dims[1], dims[2]
    plane = nx * ny
    n_motions = segments.shape[1] - 1
    for n in near:
        kn, cell = n // plane, n % plane
        i, j = cell // ny, cell % ny
        for kp in range(K):
            for m in range(n_motions):
                if (kp + deltas[kp, m, 2]) % K != kn:
                    continue
                pi, pj = i - deltas[kp, m, 0], j - deltas[kp, m, 1]
                if not (0 <= pi < nx and 0 <= pj < ny):
                    continue
                pred_cell = pi * ny + pj
                pred = kp * plane + pred_cell
                at = np.searchsorted(near, pred)
                if at < near.shape[0] and near[at] == pred:
                    continue  # entering from a near state: it was entered first
                if pred == start:
                    for b in start_bits:
                        if b == m:
                            return True
                    continue
                cx = gf[0] + (pi + 0.5) * gf[2]
                cy = gf[1] + (pj + 0.5) * gf[2]
                if at_centres.shape[0] > 0:
                    here = at_centres[pred_cell]
                else:
                    here = bilinear_at(values, geo, cx, cy)
                if here >= gf[3]:
                    return True  # open space: every motion is free (as the search has it)
                free = True
                for p in range(segments[kp, m], segments[kp, m + 1]):
                    q = inverse[kp, p]
                    if not bilinear_at(values, geo, cx + ux[kp, q], cy + uy[kp, q]) >= needs[kp, p]:
                        free = False
                        break
                if free:
                    return True
    return False

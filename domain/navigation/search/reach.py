"""Whether any sequence of valid motions reaches the goal: the lattice's own connectivity.

When the cost search's budget runs out, the relaxed checks (``domain.navigation.feasibility``)
may still say "maybe": they let through gaps a little narrower than the body, such as a sensed
wall whose cells a wide cone left below the occupied threshold. This search answers on the
lattice itself: a greedy best-first walk (by the cost heuristic) over the states every valid
motion joins, validity alone (no costs, so no cost keeps it from a way), each state once. It
finds a way quickly when there is one, and when the reachable states run out without the head
on the goal, no plan on this lattice and this lethal layer exists: a proof the cost search's
budget could not give. It reads the same validity (``costs.lethal_part``) and the same window
as the search, and stops at the task's deadline, a cancel, or ``states`` states.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from domain.kernels import jit
from domain.navigation.lattice.costs import lethal_part, state_costs
from domain.navigation.lattice.task import LatticeTask
from domain.navigation.search.heuristic import CostHeuristic, state_heuristic
from domain.pyperplan_adapter import stop_if_due
from sim.robot import Array

CHUNK = 4096  # states between checks of the deadline and the cancel flag
REACHED, NONE, OVER, RUNNING = range(4)


def lattice_reaches(task: LatticeTask, heuristic: CostHeuristic, states: int) -> bool | None:
    """``True`` when some sequence of valid motions from the task's start puts the head on its
    goal, ``False`` when none does, ``None`` when ``states`` states were met first. Raises
    ``SearchStopped`` for a cancel or the deadline."""
    grid, table, kt, inputs = task.grid, task.table, task.kt, task.inputs
    window = task.window or (slice(0, grid.nx), slice(0, grid.ny))
    wi, wj = window
    K = grid.settings.orientations
    dims = np.array([grid.nx, grid.ny, K, wi.start, wj.start, wi.stop, wj.stop], dtype=np.int64)
    start_bits, _ = state_costs(task.start_number, inputs, task.kt_start)
    seen = np.zeros(grid.size, dtype=np.bool_)
    capacity = 1 << 14
    heap_h, heap_s = np.empty(capacity), np.empty(capacity, dtype=np.int64)
    count = np.zeros(3, dtype=np.int64)  # heap size, states met, started
    near = task.near_states()
    while True:
        stop_if_due(task.cancel, task.deadline)
        status = _walk(
            CHUNK, states, task.start_number, start_bits, near, dims, inputs.values,
            inputs.geo, kt.open_need, inputs.params, kt.checks, kt.check_needs,
            kt.check_fails, kt.check_points, kt.grouped, kt.check_segments, kt.deltas,
            kt.cell_reach, kt.lengths, kt.lead_lengths, task.motion_targets, heuristic.dims, heuristic.hf,
            heuristic.values, heuristic.headings, heuristic.way, heuristic.risk, seen,
            heap_h, heap_s, count,
        )  # fmt: skip
        if status == REACHED:
            return True
        if status == NONE:
            return False
        if status == OVER:
            return None
        if int(count[0]) + len(table.motions) + 1 > len(heap_h):
            heap_h = np.concatenate([heap_h, np.empty(len(heap_h))])
            heap_s = np.concatenate([heap_s, np.empty(len(heap_s), dtype=np.int64)])


@jit
def _sift_up(h: Array, s: NDArray[np.int64], p: int) -> None:  # pragma: no cover - compiled
    while p > 0:
        parent = (p - 1) // 2
        if not h[p] < h[parent]:
            break
        h[p], h[parent] = h[parent], h[p]
        s[p], s[parent] = s[parent], s[p]
        p = parent


@jit
def _pop(h: Array, s: NDArray[np.int64], size: int) -> int:  # pragma: no cover - compiled
    top = s[0]
    last = size - 1
    h[0], s[0] = h[last], s[last]
    p = 0
    while True:
        a, b, least = 2 * p + 1, 2 * p + 2, p
        if a < last and h[a] < h[least]:
            least = a
        if b < last and h[b] < h[least]:
            least = b
        if least == p:
            break
        h[p], h[least] = h[least], h[p]
        s[p], s[least] = s[least], s[p]
        p = least
    return int(top)


@jit
def _walk(  # pragma: no cover - compiled
    chunk: int, limit: int, start: int, start_bits: int, near: NDArray[np.int64],
    dims: NDArray[np.int64], values: Array, geo: Array, open_need: float, params: Array,
    checks: Array, check_needs: Array, check_fails: Array, check_points: Array,
    grouped: Array, check_segments: Array, deltas: Array, cell_reach: Array, lengths: Array,
    lead_lengths: Array, targets: Array, h_dims: NDArray[np.int64], h_f: Array, h_values: Array,
    headings: NDArray[np.int64], h_way: Array, h_risk: Array, seen: NDArray[np.bool_],
    heap_h: Array, heap_s: NDArray[np.int64], count: NDArray[np.int64],
) -> int:  # fmt: skip
    """Up to ``chunk`` states of the walk (see the module's docstring); what it ended with."""
    nx, ny = dims[0], dims[1]
    plane = nx * ny
    n_motions = check_segments.shape[1] - 1
    base = np.empty(n_motions)
    if count[2] == 0:
        count[2] = 1
        seen[start] = True
        heap_h[0], heap_s[0] = 0.0, start
        count[0] = 1
    done = 0
    while count[0] > 0:
        if done >= chunk or count[0] + n_motions + 1 > heap_h.shape[0]:
            return RUNNING
        state = _pop(heap_h, heap_s, count[0])
        count[0] -= 1
        done += 1
        count[1] += 1
        if count[1] > limit:
            return OVER
        at = np.searchsorted(near, state)
        if at < near.shape[0] and near[at] == state:
            return REACHED
        if state == start:
            bits = start_bits
        else:
            bits = lethal_part(
                state, nx, ny, values, geo, open_need, checks, check_needs, check_fails,
                check_points, grouped, check_segments, deltas, cell_reach, lengths, lead_lengths, params,
                base,
            )  # fmt: skip
        k, cell = state // plane, state % plane
        for m in range(n_motions):
            if not (bits >> m) & 1:
                continue
            b = targets[k, m] + cell
            if b == state or seen[b]:
                continue
            bc = b % plane
            bi, bj = bc // ny, bc % ny
            if not (dims[3] <= bi < dims[5] and dims[4] <= bj < dims[6]):
                continue
            seen[b] = True
            h = state_heuristic(b, h_dims, h_f, h_values, headings, h_way, h_risk)
            if h == math.inf:
                continue  # the 2-D map proves no way on from there
            p = count[0]
            heap_h[p], heap_s[p] = h, b
            _sift_up(heap_h, heap_s, p)
            count[0] = p + 1
    return NONE

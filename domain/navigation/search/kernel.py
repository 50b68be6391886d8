"""The cost search compiled: ``cost_astar_search`` on a ``LatticeTask``, step for step, in numba.

The same open list order (``(g + weight * h, h, tiebreaker)``), the same successors in the same
order (a goal visit first, then the valid motions by index), the same costs (``costs.evaluate``)
and heuristic values (``heuristic.state_heuristic``), the same stale-entry test, closed states
(expanded once), expansion count, budget and best node. A state's valid motions and costs are read from, or added to, the motion
cache's rows; the best node of each state met is kept in a hash table (``lattice.store``; a
visited goal's state under ``-(number + 1)``; an expanded state's node as ``-(node + 1)``:
closed). The Python side (``search``) prepares the
arrays, grows them when the kernel asks, and checks the deadline and cancellation between
chunks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pyperplan.task import Operator

from domain.kernels import jit
from domain.navigation.lattice.costs import lethal_part, risk_part
from domain.navigation.lattice.store import MAX_LOAD, Store, put, slot
from domain.navigation.lattice.task import CostOperator, LatticeTask, state_name
from domain.navigation.search.heuristic import CostHeuristic, state_heuristic
from domain.pyperplan_adapter import stop_if_due
from sim.robot import Array

CHUNK = 256  # expansions between checks of the deadline and the cancel flag
FIRST_NODES = 8192  # room for search nodes at first (doubled when full)
MAX_MOTIONS = 62  # motions per state a bitmask holds
HEAP_WIDTH = 4  # an open-list entry: f, h, tiebreaker, node

# Counters (``count``): nodes made, heap size, pushes (the tiebreaker), expansions, best node,
# states expanded (recorded), the goal node, whether the weight went up (``Stall``).
NODES, HEAP, TIE, EXPANSIONS, BEST, EXPANDED, GOAL, STALLED = range(8)
COUNTERS = 8
NEVER = 1 << 62  # expansions of a search that never stalls
# What a chunk ended with.
RUNNING, SOLVED, EXHAUSTED, OVER_BUDGET, NEED_ROOM = range(5)


@dataclass(frozen=True)
class Stall:
    """A search that has spent ``after`` expansions without a plan goes on at ``weight``
    (higher than its first): every open entry re-keyed at once, so the rest of the search
    follows the heuristic more greedily. Expansions that many are where the heuristic
    underestimates the way's costs most (a way round an obstacle the heuristic's cells do not
    price as the body's sweep does): the plan's cost bound loosens to ``weight`` times the
    best's, as an anytime search's first answer does, instead of the budget running out."""

    after: int
    weight: float


@dataclass
class Found:
    """A finished search: ``solved`` (``plan`` reaches the goal), ``exhausted`` (the reachable
    states ran out: no plan exists on this lattice) or ``budget`` (the expansions ran out), and
    the best expanded node's h and path (the anytime answer)."""

    status: str
    plan: list[Operator] | None
    best_h: float
    best: list[Operator]
    expansions: int


def applies(task: Any, heuristic: Any) -> bool:
    """Whether the compiled search can run this task with this heuristic."""
    return (
        isinstance(task, LatticeTask)
        and type(heuristic) is CostHeuristic
        and len(task.table.motions) <= MAX_MOTIONS
    )


class _Nodes:
    """The arrays of one search, grown as it goes."""

    GROWN = ("state", "parent", "g", "op", "h", "heap")

    def __init__(self, capacity: int, n_motions: int) -> None:
        self.state = np.empty(capacity, dtype=np.int64)
        self.parent = np.empty(capacity, dtype=np.int64)
        self.g = np.empty(capacity)
        self.op = np.empty(capacity, dtype=np.int64)
        self.h = np.empty(capacity)
        # The open list: one row per entry (f, h, tiebreaker, node; the last two exact in a
        # float below 2^53), so a heap step reads one place, not four arrays.
        self.heap = np.empty((capacity, HEAP_WIDTH))
        self.exp_number = np.empty(capacity // 8, dtype=np.int64)
        self.exp_bits = np.empty(capacity // 8, dtype=np.int64)
        self.exp_costs = np.empty((capacity // 8, max(1, n_motions)))
        self.exp_near = np.empty(capacity // 8, dtype=np.bool_)
        self.count = np.zeros(COUNTERS, dtype=np.int64)
        self.best_h = np.array([math.inf])

    def grow(self, more: int) -> None:
        """Room for ``more`` nodes and one more expanded state."""
        if int(self.count[NODES]) + more + 1 > len(self.state):
            for name in self.GROWN:
                old = getattr(self, name)
                new = np.empty((2 * len(old), *old.shape[1:]), dtype=old.dtype)
                new[: len(old)] = old
                setattr(self, name, new)
        if int(self.count[EXPANDED]) >= len(self.exp_number):
            n = 2 * len(self.exp_number)
            for name in ("exp_number", "exp_bits", "exp_near"):
                old = getattr(self, name)
                new = np.empty(n, dtype=old.dtype)
                new[: len(old)] = old
                setattr(self, name, new)
            costs = np.empty((n, self.exp_costs.shape[1]))
            costs[: len(self.exp_costs)] = self.exp_costs
            self.exp_costs = costs

    def operators(self, task: LatticeTask, node: int) -> list[Operator]:
        """The operators from the root to ``node`` (as pyperplan's ``extract_solution``)."""
        names = task.table.names
        out: list[Operator] = []
        while node > 0:
            parent = int(self.parent[node])
            a, m = int(self.state[parent]), int(self.op[node])
            here = frozenset([task.fact(a)])
            cost = float(self.g[node] - self.g[parent])
            if m < 0:
                name = f"(visit {state_name(a)} g{task.goal_index})"
                out.append(
                    CostOperator.of(name, here, frozenset([task.goal_fact]), frozenset(), cost)
                )
            else:
                b = int(self.state[node])
                name = f"(move {state_name(a)} {state_name(b)} {names[m]})"
                out.append(CostOperator.of(name, here, frozenset([task.fact(b)]), here, cost))
            node = parent
        out.reverse()
        return out


def search(
    task: LatticeTask,
    heuristic: CostHeuristic,
    weight: float,
    budget: int,
    stall: Stall | None = None,
) -> Found:
    """``cost_astar_search(task, heuristic, weight, budget, stall=stall)`` compiled
    (``applies`` says when it can run). Raises ``SearchStopped`` for a cancel or the deadline;
    the budget ends the search with its best node (``Found.plan`` ``None`` and ``best`` the way
    there)."""
    stall_after, stall_weight = (NEVER, weight) if stall is None else (stall.after, stall.weight)
    grid, table = task.grid, task.table
    kt, inputs = task.kt, task.inputs
    start = task.start_number
    start_bits, start_costs = task.start_costs()
    dims = np.array([grid.nx, grid.ny, grid.settings.orientations], dtype=np.int64)
    cache = task.cache
    if cache is None:
        raise ValueError("the compiled search needs the task's motion cache")
    best_of = Store(FIRST_NODES)
    lethal, risky = cache.lethal, cache.risk
    n_motions = len(table.motions)
    s = _Nodes(FIRST_NODES, n_motions)
    near_states = task.near_states()
    status = RUNNING
    try:
        while True:
            stop_if_due(task.cancel, task.deadline)
            status = _run(
                CHUNK, budget, weight, stall_after, stall_weight, start, start_bits,
                start_costs, near_states, dims,
                inputs.values, inputs.geo, inputs.risk, inputs.blocked, inputs.flat,
                kt.open_need, inputs.params, kt.check_unique, kt.check_unique_counts,
                kt.check_cells, kt.check_needs, kt.check_fails, kt.check_points, kt.grouped,
                kt.check_segments, kt.deltas, kt.cell_reach, kt.lengths, kt.lead_lengths,
                kt.new_unique, kt.new_unique_counts, kt.blind_segments, kt.blind_cells,
                kt.seen_segments, kt.seen_cells, kt.cell_counts, task.motion_targets,
                heuristic.dims, heuristic.hf, heuristic.values, heuristic.risk,
                lethal.index.keys, lethal.index.values, lethal.index.size, lethal.ints,
                lethal.floats, lethal.used, risky.index.keys, risky.index.values,
                risky.index.size, risky.floats, risky.used,
                best_of.keys, best_of.values, best_of.size,
                s.state, s.parent, s.g, s.op, s.h, s.heap, s.count, s.best_h,
                s.exp_number, s.exp_bits, s.exp_costs, s.exp_near,
            )  # fmt: skip
            if status == NEED_ROOM:
                s.grow(n_motions + 1)
                best_of.room(n_motions + 2)
                lethal.room(1)
                risky.room(1)
                lethal, risky = cache.lethal, cache.risk  # (rows may start afresh)
            elif status in (SOLVED, EXHAUSTED, OVER_BUDGET):
                break
    finally:
        task.expansions = int(s.count[EXPANSIONS])
        n = int(s.count[EXPANDED])
        task.expanded(
            s.exp_number[:n].copy(), s.exp_bits[:n].copy(), s.exp_costs[:n].copy(),
            s.exp_near[:n].copy(),
        )  # fmt: skip
    best = int(s.count[BEST])
    plan = s.operators(task, int(s.count[GOAL])) if status == SOLVED else None
    path = s.operators(task, best) if best >= 0 and plan is None else []
    outcome = {SOLVED: "solved", EXHAUSTED: "exhausted"}.get(status, "budget")
    return Found(outcome, plan, float(s.best_h[0]), path, task.expansions)


@jit
def _before(  # pragma: no cover - compiled
    heap: Array, a: int, f: float, h: float, tie: float
) -> bool:
    """Whether entry ``a`` comes before the key ``(f, h, tie)``."""
    if heap[a, 0] != f:
        return bool(heap[a, 0] < f)
    if heap[a, 1] != h:
        return bool(heap[a, 1] < h)
    return bool(heap[a, 2] < tie)


@jit
def _push(  # pragma: no cover - compiled
    heap: Array, size: int, f: float, h: float, tie: int, node: int
) -> int:
    """Push onto the 4-ary heap of ``size`` entries; the new size. Keys are unique (the
    tiebreaker), so any heap pops ``heapq``'s order; four children side by side take fewer
    levels and fewer places read than two."""
    p = size
    while p > 0:
        parent = (p - 1) >> 2
        if _before(heap, parent, f, h, tie):
            break
        heap[p, 0], heap[p, 1] = heap[parent, 0], heap[parent, 1]  # the parent moves down
        heap[p, 2], heap[p, 3] = heap[parent, 2], heap[parent, 3]
        p = parent
    heap[p, 0], heap[p, 1], heap[p, 2], heap[p, 3] = f, h, tie, node
    return size + 1


@jit
def _pop(heap: Array, size: int) -> int:  # pragma: no cover - compiled
    """Take the least entry's node off the heap of ``size`` entries."""
    top = int(heap[0, 3])
    last = size - 1
    _sift_down(heap, last, 0, heap[last, 0], heap[last, 1], heap[last, 2], heap[last, 3])
    return top


@jit
def _sift_down(  # pragma: no cover - compiled
    heap: Array, size: int, p: int, f: float, h: float, tie: float, node: float
) -> None:
    """Put the entry ``(f, h, tie, node)`` at place ``p`` of the heap's first ``size``
    entries, moving the lesser child up until none comes before it."""
    while True:
        first = 4 * p + 1
        if first >= size:
            break
        least = first
        for c in range(first + 1, min(first + 4, size)):
            if _before(heap, c, heap[least, 0], heap[least, 1], heap[least, 2]):
                least = c
        if not _before(heap, least, f, h, tie):
            break
        heap[p, 0], heap[p, 1] = heap[least, 0], heap[least, 1]
        heap[p, 2], heap[p, 3] = heap[least, 2], heap[least, 3]
        p = least
    heap[p, 0], heap[p, 1], heap[p, 2], heap[p, 3] = f, h, tie, node


@jit
def _rekey(  # pragma: no cover - compiled
    heap: Array, size: int, node_g: Array, weight: float
) -> None:
    """Every open entry's f at ``weight`` (g of its node + weight x its h), the heap rebuilt
    bottom up."""
    for e in range(size):
        heap[e, 0] = node_g[int(heap[e, 3])] + weight * heap[e, 1]
    for p in range((size - 2) // 4, -1, -1):
        _sift_down(heap, size, p, heap[p, 0], heap[p, 1], heap[p, 2], heap[p, 3])


@jit
def _run(  # pragma: no cover - compiled
    chunk: int, budget: int, weight: float, stall_after: int, stall_weight: float, start: int,
    start_bits: int, start_costs: Array,
    near_states: NDArray[np.int64], dims: NDArray[np.int64], values: Array, geo: Array,
    risk: Array, blocked: Array, flat: Array, open_need: float, params: Array,
    check_unique: Array, check_unique_counts: Array, check_cells: Array,
    check_needs: Array, check_fails: Array, check_points: Array,
    grouped: Array, check_segments: Array, deltas: Array, cell_reach: Array,
    lengths: Array, lead_lengths: Array, new_unique: Array, new_unique_counts: Array,
    blind_segments: Array, blind_cells: Array, seen_segments: Array, seen_cells: Array,
    cell_counts: Array, targets: Array,
    h_dims: NDArray[np.int64], h_f: Array, h_values: Array, h_risk: Array,
    lk: Array, lv: Array, ls: Array, lethal_bits: Array, lethal_base: Array, lethal_used: Array,
    rk: Array, rv: Array, rs: Array, risk_extra: Array, risk_used: Array,
    bk: Array, bv: Array, bs: Array,
    node_state: Array, node_parent: Array, node_g: Array, node_op: Array, node_h: Array,
    heap: Array, count: Array, best_h: Array,
    exp_number: Array, exp_bits: Array, exp_costs: Array, exp_near: Array,
) -> int:  # fmt: skip
    """Up to ``chunk`` expansions (see the module's docstring); what it ended with. The first
    call pushes the root (``count`` all zero). Once ``stall_after`` expansions are spent, the
    open list is re-keyed at ``stall_weight`` and the search goes on at it (``Stall``)."""
    nx, ny = dims[0], dims[1]
    plane = nx * ny
    n_motions = check_segments.shape[1] - 1
    cap = node_state.shape[0]
    here_costs = np.empty(n_motions)
    base = np.empty(n_motions)
    extra = np.empty(n_motions)
    at_cells = np.empty(check_unique.shape[1])  # (the evaluations' scratch)
    at_risk = np.empty(new_unique.shape[1])
    at_blocked = np.empty(new_unique.shape[1])
    if count[NODES] == 0:
        h = state_heuristic(start, h_dims, h_f, h_values, h_risk)
        node_state[0], node_parent[0], node_g[0], node_op[0], node_h[0] = start, -1, 0.0, -2, h
        count[BEST] = -1
        put(bk, bv, bs, start, 0)
        count[NODES] = 1
        count[HEAP] = _push(heap, 0, weight * h, h, 0, 0)
    if count[STALLED]:
        weight = stall_weight
    done = 0
    while count[HEAP] > 0:
        if done >= chunk:
            return RUNNING
        if count[EXPANSIONS] >= stall_after and not count[STALLED]:
            count[STALLED] = 1
            weight = stall_weight
            _rekey(heap, count[HEAP], node_g, weight)
        if (
            count[NODES] + n_motions + 1 > cap
            or count[EXPANDED] >= exp_number.shape[0]
            or bs[0] + n_motions + 2 > MAX_LOAD * bk.shape[0]
            or ls[0] + 1 > MAX_LOAD * lk.shape[0]
            or lethal_used[0] + 1 > lethal_bits.shape[0]
            or rs[0] + 1 > MAX_LOAD * rk.shape[0]
            or risk_used[0] + 1 > risk_extra.shape[0]
        ):
            return NEED_ROOM
        node = _pop(heap, count[HEAP])
        count[HEAP] -= 1
        state = node_state[node]
        here = slot(bk, state)
        if bv[here] != node:
            continue  # expanded already, or a cheaper path to it was found since
        if state < 0:
            count[GOAL] = node
            return SOLVED
        if count[EXPANSIONS] >= budget:
            return OVER_BUDGET  # (the pop that finds it spent is no expansion)
        count[EXPANSIONS] += 1
        done += 1
        bv[here] = -(node + 1)  # closed
        k, cell = state // plane, state % plane
        if state == start:
            bits = start_bits
            for m in range(n_motions):
                here_costs[m] = start_costs[m]
        else:
            at = slot(lk, state)
            if lk[at] == state:
                row = lv[at]
                bits = lethal_bits[row]
                for m in range(n_motions):
                    base[m] = lethal_base[row, m]
            else:
                bits = lethal_part(
                    state, nx, ny, values, geo, open_need, check_unique, check_unique_counts,
                    check_cells, check_needs, check_fails, check_points, grouped, check_segments,
                    deltas, cell_reach, lengths, lead_lengths, params, base, at_cells,
                )  # fmt: skip
                row = lethal_used[0]
                lethal_bits[row] = bits
                for m in range(n_motions):
                    lethal_base[row, m] = base[m]
                lethal_used[0] = row + 1
                put(lk, lv, ls, state, row)
            at = slot(rk, state)
            if rk[at] == state:
                row = rv[at]
                for m in range(n_motions):
                    extra[m] = risk_extra[row, m]
            else:
                risk_part(
                    state, nx, ny, risk, blocked, flat, new_unique, new_unique_counts,
                    blind_segments, blind_cells, seen_segments, seen_cells, cell_counts, params,
                    extra, at_risk, at_blocked,
                )  # fmt: skip
                row = risk_used[0]
                for m in range(n_motions):
                    risk_extra[row, m] = extra[m]
                risk_used[0] = row + 1
                put(rk, rv, rs, state, row)
            for m in range(n_motions):
                here_costs[m] = base[m] + extra[m]
        at = np.searchsorted(near_states, state)
        is_near = at < near_states.shape[0] and near_states[at] == state
        e = count[EXPANDED]
        exp_number[e], exp_bits[e], exp_near[e] = state, bits, is_near
        for m in range(n_motions):
            exp_costs[e, m] = here_costs[m]
        count[EXPANDED] = e + 1
        if bits != 0 and node_h[node] < best_h[0]:
            best_h[0], count[BEST] = node_h[node], node
        g = node_g[node]
        if is_near:  # the goal visit comes first (cost 0, heuristic 0)
            visited = -(state + 1)
            at = slot(bk, visited)
            if bk[at] != visited or g < node_g[bv[at]]:
                child = count[NODES]
                count[NODES] += 1
                node_state[child], node_parent[child], node_g[child] = visited, node, g
                node_op[child], node_h[child] = -1, 0.0
                count[TIE] += 1
                count[HEAP] = _push(heap, count[HEAP], g, 0.0, count[TIE], child)
                put(bk, bv, bs, visited, child)
        for m in range(n_motions):
            if not (bits >> m) & 1:
                continue
            b = targets[k, m] + cell
            if b == state:
                continue
            at = slot(bk, b)
            if bk[at] == b and bv[at] < 0:
                continue  # no reopening
            g_child = g + here_costs[m]
            met = bk[at] == b
            if met and not g_child < node_g[bv[at]]:
                continue  # reached as cheaply already
            # (a state's heuristic value is its own: one met already keeps the one it had)
            h = node_h[bv[at]] if met else state_heuristic(b, h_dims, h_f, h_values, h_risk)
            if h == math.inf:
                continue  # no way to the goal from there
            child = count[NODES]
            count[NODES] += 1
            node_state[child], node_parent[child], node_g[child] = b, node, g_child
            node_op[child], node_h[child] = m, h
            count[TIE] += 1
            count[HEAP] = _push(heap, count[HEAP], g_child + weight * h, h, count[TIE], child)
            put(bk, bv, bs, b, child)
    return EXHAUSTED

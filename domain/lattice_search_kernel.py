"""The compiled (numba) loop of the lattice search: pyperplan's greedy best-first search over
the lattice task, expanding states in chunks.

It is ``pyperplan.search.a_star.astar_search`` with ``ordered_node_greedy_best_first`` on a
``LatticeTask`` inside ``search_reached``, step for step: the same open list order (by
heuristic value, then by when a node was pushed), the same successors in the same order
(a goal visit first, then the free motions by motion index, those already reached in as few
moves left out), the same heuristic values (``LatticeHeuristic`` or the repair's
``RejoinHeuristic``, with CPython's ``math.remainder``), the same expansion count and budget.
A state's free motions are a bitmask (bit ``m``: motion ``m``), looked up in or added to the
motion cache's compiled store; the least moves to each state met are kept in a second store
(domain/lattice_store.py; a visited goal's state under ``-(number + 1)``). The Python side (domain/lattice_search.py) prepares the arrays,
grows them when the kernel asks, and checks the deadline and cancellation between chunks.
"""

from __future__ import annotations

import math

import numpy as np

from domain.lattice_motion_kernel import free_bits
from domain.lattice_store import MAX_LOAD, put, slot
from domain.occupancy_kernel import _jit
from sim.robot import Array

# Counters (``count``): nodes made, heap size, pushes (the tiebreaker), expansions, best node,
# states expanded (recorded), the goal node.
NODES, HEAP, TIE, EXPANSIONS, BEST, EXPANDED, GOAL = range(7)
COUNTERS = 7
# What a chunk ended with.
RUNNING, SOLVED, EXHAUSTED, OVER_BUDGET, NEED_ROOM = range(5)
# Heuristics: the planner's lattice heuristic, the repair's rejoin heuristic.
LATTICE, REJOIN = 0, 1
HEAD_WEIGHT, ALIGN_WEIGHT = 0.5, 2.0  # LatticeHeuristic's (a test holds them equal)


@_jit
def remainder(x: float, y: float) -> float:  # pragma: no cover - compiled
    """CPython's ``math.remainder`` (``m_remainder``) for finite ``x`` and ``y != 0``: fmod,
    then the nearest multiple, halfway cases to the even one (every step exact)."""
    absx, absy = abs(x), abs(y)
    m = np.fmod(absx, absy)
    c = absy - m
    if m < c:
        r = m
    elif m > c:
        r = -c
    else:
        r = m - 2.0 * np.fmod(0.5 * (absx - m), absy)
    return float(math.copysign(1.0, x) * r)


@_jit
def _less(h: Array, tie: Array, a: int, b: int) -> bool:  # pragma: no cover - compiled
    return bool(h[a] < h[b] or (h[a] == h[b] and tie[a] < tie[b]))


@_jit
def _push(  # pragma: no cover - compiled
    hh: Array, ht: Array, hn: Array, size: int, h: float, tie: int, node: int
) -> int:
    """Push onto the binary heap (``hh``, ``ht``, ``hn``: keys, tiebreakers, nodes); the new
    size. Keys are unique (the tiebreaker), so any heap pops pyperplan's ``heapq`` order."""
    p = size
    hh[p], ht[p], hn[p] = h, tie, node
    while p > 0:
        parent = (p - 1) // 2
        if not _less(hh, ht, p, parent):
            break
        hh[p], hh[parent] = hh[parent], hh[p]
        ht[p], ht[parent] = ht[parent], ht[p]
        hn[p], hn[parent] = hn[parent], hn[p]
        p = parent
    return size + 1


@_jit
def _pop(hh: Array, ht: Array, hn: Array, size: int) -> int:  # pragma: no cover - compiled
    """Take the least entry's node off the heap of ``size`` entries."""
    top = hn[0]
    last = size - 1
    hh[0], ht[0], hn[0] = hh[last], ht[last], hn[last]
    p = 0
    while True:
        a, b, least = 2 * p + 1, 2 * p + 2, p
        if a < last and _less(hh, ht, a, least):
            least = a
        if b < last and _less(hh, ht, b, least):
            least = b
        if least == p:
            break
        hh[p], hh[least] = hh[least], hh[p]
        ht[p], ht[least] = ht[least], ht[p]
        hn[p], hn[least] = hn[least], hn[p]
        p = least
    return int(top)


@_jit
def heuristic(  # pragma: no cover - compiled
    number: int,
    kind: int,
    dims: Array,
    hf: Array,
    base: Array,
    way: Array,
    narrow: Array,
    window_dist: Array,
    ks: Array,
) -> float:
    """The heuristic of a (not visited) state. ``dims``: nx, ny, K, window i0, j0; ``hf``:
    turn step, step (rejoin), largest turn (rejoin)."""
    nx, ny = dims[0], dims[1]
    plane = nx * ny
    if kind == LATTICE:
        k, cell = number // plane, number % plane
        h = base[cell]
        w = way[cell]
        psi = k * hf[0]
        h += HEAD_WEIGHT * abs(remainder(psi + math.pi - w, 2 * math.pi)) / math.pi
        if narrow[cell]:
            h += ALIGN_WEIGHT * abs(remainder(psi - w, math.pi)) / (math.pi / 2)
        return float(h)
    rest, j = number // ny, number % ny
    k, i = rest // nx, rest % nx
    di, dj = i - dims[3], j - dims[4]
    if di < 0:  # (Python's negative index, as the list the heuristic reads)
        di += window_dist.shape[0]
    if dj < 0:
        dj += window_dist.shape[1]
    d = window_dist[di, dj]
    if not math.isfinite(d):
        return math.inf
    dk = math.inf
    for t in ks:
        e = abs(remainder((k - t) * hf[0], 2 * math.pi))
        if e < dk:
            dk = e
    return float(d / hf[1] + dk / hf[2])


@_jit
def run(  # pragma: no cover - compiled
    chunk: int,
    budget: int,
    start: int,
    start_bits: int,
    near_states: Array,
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
    targets: Array,
    kind: int,
    hf: Array,
    base: Array,
    way: Array,
    narrow: Array,
    window_dist: Array,
    ks: Array,
    ck: Array,
    cv: Array,
    cs: Array,
    use_cache: bool,
    tk: Array,
    tv: Array,
    ts: Array,
    node_state: Array,
    node_parent: Array,
    node_g: Array,
    node_op: Array,
    hh: Array,
    ht: Array,
    hn: Array,
    count: Array,
    best_h: Array,
    exp_number: Array,
    exp_bits: Array,
    exp_near: Array,
) -> int:
    """Up to ``chunk`` expansions of the search whose state is in the arrays (see the module's
    docstring); what it ended with. A visited goal's state is ``-(number + 1)``. ``dims``: nx,
    ny, K, window i0, j0, i1, j1 (the cells successors may lie in). The first call pushes the
    root (``count`` all zero)."""
    scratch = np.empty((3, ux.shape[1]))  # a state's clearance at its bin's distinct points
    if count[NODES] == 0:  # the root: pushed whatever its heuristic
        h = heuristic(start, kind, dims, hf, base, way, narrow, window_dist, ks)
        node_state[0], node_parent[0], node_g[0], node_op[0] = start, -1, 0, -2
        best_h[0], count[BEST] = h, 0
        put(tk, tv, ts, start, 0)
        count[NODES] = 1
        count[HEAP] = _push(hh, ht, hn, 0, h, 0, 0)
    status = _expand(
        chunk, budget, start, start_bits, near_states, dims, gf, at_centres, values,
        geo, ux, uy, inverse, needs, segments, deltas, cell_reach, n_unique, targets,
        kind, hf, base, way, narrow, window_dist, ks, ck, cv, cs, use_cache, tk, tv, ts, node_state,
        node_parent, node_g, node_op, hh, ht, hn, count, best_h, exp_number, exp_bits,
        exp_near, scratch,
    )  # fmt: skip
    return int(status)


@_jit
def _expand(  # pragma: no cover - compiled
    chunk: int, budget: int, start: int, start_bits: int, near_states: Array,
    dims: Array, gf: Array, at_centres: Array, values: Array,
    geo: Array, ux: Array, uy: Array, inverse: Array, needs: Array, segments: Array,
    deltas: Array, cell_reach: Array, n_unique: Array, targets: Array,
    kind: int, hf: Array, base: Array, way: Array, narrow: Array, window_dist: Array, ks: Array,
    ck: Array, cv: Array, cs: Array, use_cache: bool, tk: Array, tv: Array, ts: Array,
    node_state: Array, node_parent: Array, node_g: Array, node_op: Array,
    hh: Array, ht: Array, hn: Array, count: Array, best_h: Array,
    exp_number: Array, exp_bits: Array, exp_near: Array, scratch: Array,
) -> int:  # fmt: skip
    """``run``'s loop."""
    nx, ny = dims[0], dims[1]
    plane = nx * ny
    n_motions = segments.shape[1] - 1
    cap = node_state.shape[0]
    done = 0
    while count[HEAP] > 0:
        if done >= chunk:
            return RUNNING
        if (
            count[NODES] + n_motions + 1 > cap
            or count[EXPANDED] >= exp_number.shape[0]
            or ts[0] + n_motions + 2 > MAX_LOAD * tk.shape[0]
            or cs[0] + 1 > MAX_LOAD * ck.shape[0]
        ):
            return NEED_ROOM
        node = _pop(hh, ht, hn, count[HEAP])
        count[HEAP] -= 1
        state = node_state[node]
        if tv[slot(tk, state)] != node_g[node]:
            continue  # reached in fewer moves since it was pushed
        if state < 0:
            count[GOAL] = node
            return SOLVED
        count[EXPANSIONS] += 1
        done += 1
        if count[EXPANSIONS] > budget:
            return OVER_BUDGET
        k, cell = state // plane, state % plane
        if state == start:
            bits = start_bits
        elif use_cache and ck[slot(ck, state)] == state:
            bits = cv[slot(ck, state)]
        else:
            bits = free_bits(
                state,
                dims,
                gf,
                at_centres,
                values,
                geo,
                ux,
                uy,
                inverse,
                needs,
                segments,
                deltas,
                cell_reach,
                n_unique,
                scratch,
            )
            if use_cache:
                put(ck, cv, cs, state, bits)
        at = np.searchsorted(near_states, state)
        is_near = at < near_states.shape[0] and near_states[at] == state
        e = count[EXPANDED]
        exp_number[e], exp_bits[e], exp_near[e] = state, bits, is_near
        count[EXPANDED] = e + 1
        g = node_g[node] + 1
        if is_near:  # the goal visit comes first (its heuristic is 0)
            visited = -(state + 1)
            child = count[NODES]
            count[NODES] += 1
            node_state[child], node_parent[child], node_g[child], node_op[child] = (
                visited,
                node,
                g,
                -1,
            )
            # (its heuristic answers 0 without taking it for the best node)
            at = slot(tk, visited)
            if tk[at] != visited or g < tv[at]:
                count[TIE] += 1
                count[HEAP] = _push(hh, ht, hn, count[HEAP], 0.0, count[TIE], child)
                put(tk, tv, ts, visited, g)
        for m in range(n_motions):
            if not (bits >> m) & 1:
                continue
            b = targets[k, m] + cell
            if b == state:
                continue
            bc = b % plane
            bi, bj = bc // ny, bc % ny
            if not (dims[3] <= bi < dims[5] and dims[4] <= bj < dims[6]):
                continue  # outside the repair's window
            at = slot(tk, b)
            if tk[at] == b and tv[at] <= g:
                continue  # already reached in as few moves: the search would drop it
            put(tk, tv, ts, b, g)
            child = count[NODES]
            count[NODES] += 1
            node_state[child], node_parent[child], node_g[child], node_op[child] = (
                b,
                node,
                g,
                m,
            )
            h = heuristic(b, kind, dims, hf, base, way, narrow, window_dist, ks)
            if count[BEST] < 0 or h < best_h[0]:
                best_h[0], count[BEST] = h, child
            if h == math.inf:
                continue  # the search does not bother with states that cannot reach the goal
            count[TIE] += 1
            count[HEAP] = _push(hh, ht, hn, count[HEAP], h, count[TIE], child)
    return EXHAUSTED

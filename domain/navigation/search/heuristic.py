"""The search's heuristic: Smac's obstacle heuristic, a cost-aware 2-D distance to the goal.

A Dijkstra from the goal over the cells the body's centroid can occupy (its clearance keeps the
centroid's own need, less the half cell diagonal it may sit off a centre: a relaxation, so a
cell it cannot reach no body motion reaches either), 8-connected, each step costing its length
times ``1 + inflation_penalty x closeness`` at the cells it joins, closeness measured from the
corridor's centre line (the clearance beyond a unit's radius and the margin). So the heuristic
already prefers the roomy way the motions' costs prefer, and an infinite distance at the start
is the first hard proof that a goal is cut off. Cells within the goal's reach with a straight
way to it, and the robot's own round its start, are passable whatever their clearance.

A state's heuristic value is the map at its centroid's cell less how far the centroid may stay
from the goal with the head on it, plus the cheapest way to turn onto the map's way.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pyperplan.heuristics.heuristic_base import Heuristic

from domain.kernels import AVAILABLE, jit
from domain.navigation.lattice.grid import LatticeGrid
from domain.navigation.lattice.states import LatticeState
from domain.navigation.settings import CostSettings
from domain.world.grid import cells_round
from sim.robot import DEFAULT_GEOMETRY, Array


def closeness(slack: Array, costs: CostSettings) -> Array:
    """Nav2's inflation decay of a slack (m beyond the need and the margin): 1 at 0, falling by
    e every ``inflation_decay``, 0 past ``inflation_radius``."""
    s = np.maximum(slack, 0.0)
    out: Array = np.where(s < costs.inflation_radius, np.exp(-s / costs.inflation_decay), 0.0)
    return out


def step_weights(
    at_centres: Array,
    margin: float,
    costs: CostSettings,
    continuation: Array | None = None,
    resolution: float = 0.05,
) -> Array:
    """Per cell, what a metre through it costs the heuristic: ``1 + penalty x closeness`` of a
    unit's radius at the cell centre, plus, with ``continuation`` (log P(free) per cell of
    sensed obstacles going on), ``blocked_cost`` per cell's worth of it crossed (the cost of
    crossing a band of such cells is at most that of the body's sweep through them)."""
    slack = at_centres - DEFAULT_GEOMETRY.unit_radius - margin
    out: Array = 1.0 + costs.inflation_penalty * closeness(slack, costs)
    if continuation is not None:
        out = out - costs.blocked_cost * continuation / resolution
    return out


def cost_map(
    grid: LatticeGrid,
    at_centres: Array,
    goal: tuple[float, float],
    need: float,
    free: float,
    weights: Array,
    start: tuple[float, float] | None = None,
    roomy: float | None = None,
    narrow_weight: float = 1.0,
    turning: float | None = None,
    cramped_weight: float = 1.0,
) -> Array:
    """Cost-aware geodesic distance (m) from ``goal`` to every centroid cell ``[nx, ny]`` over
    the cells whose centre keeps ``need`` less half a cell diagonal (``at_centres``: the lethal
    clearance at ``grid.centres``); cells within ``free`` of the goal with a straight way to
    it, and those round ``start``, are passable. With ``roomy``, a cell whose clearance is
    below it (where the body's footprint cannot keep the margin) costs ``narrow_weight`` times
    as much, and with ``turning`` one below that (where the body cannot change its heading:
    a bent passage it cannot take) ``cramped_weight`` times: the map is still the relaxation
    the proofs read (its infinities are unchanged), and it leads the search the way the body
    fits and can turn. ``inf`` where cut off."""
    r = grid.settings.resolution
    ok = at_centres >= need - r * math.sqrt(0.5)
    if turning is not None and cramped_weight != 1.0:
        weights = np.where(at_centres >= turning, weights, weights * cramped_weight)
    if roomy is not None and narrow_weight != 1.0:
        weights = np.where(at_centres >= roomy, weights, weights * narrow_weight)
    ok |= in_reach(grid, at_centres, goal, free)
    if start is not None:  # the robot is there: it may be touching what it just bumped into
        ok[cells_within(grid, start, grid.settings.search.start_free)] = True
    gi, gj = grid.cell(*goal)
    return weighted_geodesic(
        ok.reshape(grid.nx, grid.ny), weights.reshape(grid.nx, grid.ny), [(gi, gj)], r
    )


def in_reach(
    grid: LatticeGrid, at_centres: Array, goal: tuple[float, float], free: float
) -> NDArray[np.bool_]:
    """The cells within ``free`` of the goal whose straight way to it keeps a unit's radius
    clear: from there the body reaches the goal with its head (without the way test, a map
    leaks through thin walls: a cell behind a wall next to the goal looks almost there)."""
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


def weighted_geodesic(
    ok: NDArray[np.bool_], weights: Array, sources: Sequence[tuple[int, int]], r: float
) -> Array:
    """Dijkstra distances (m) from the nearest of ``sources`` over the 8-connected cells where
    ``ok`` (``[nx, ny]``), a step between two cells costing its length times the mean of their
    ``weights``; ``inf`` where cut off."""
    nx, ny = ok.shape
    index = np.array([i * ny + j for i, j in sources], dtype=np.int64)
    dist = np.full(nx * ny, np.inf)
    flat_ok = np.ascontiguousarray(ok).ravel()
    flat_w = np.ascontiguousarray(weights, dtype=np.float64).ravel()
    if AVAILABLE:
        _dijkstra(flat_ok, flat_w, nx, ny, index, r, r * math.sqrt(2.0), dist)
    else:
        _dijkstra_python(flat_ok, flat_w, nx, ny, index, r, r * math.sqrt(2.0), dist)
    return dist.reshape(nx, ny)


_DI = (1, -1, 0, 0, 1, 1, -1, -1)
_DJ = (0, 0, 1, -1, 1, -1, 1, -1)


def _dijkstra_python(
    ok: NDArray[np.bool_],
    w: Array,
    nx: int,
    ny: int,
    sources: NDArray[np.int64],
    axial: float,
    diagonal: float,
    dist: Array,
) -> None:
    """``_dijkstra`` in Python (no numba): the same loop, the same sums."""
    heap: list[tuple[float, int]] = []
    for s in sources.tolist():
        dist[s] = 0.0
        heapq.heappush(heap, (0.0, s))
    done = np.zeros(nx * ny, dtype=bool)
    while heap:
        du, u = heapq.heappop(heap)
        if done[u] or du > dist[u]:
            continue
        done[u] = True
        if not ok[u]:
            continue
        ui, uj = divmod(u, ny)
        for e in range(8):
            vi, vj = ui + _DI[e], uj + _DJ[e]
            if not (0 <= vi < nx and 0 <= vj < ny):
                continue
            v = vi * ny + vj
            if done[v] or not ok[v]:
                continue
            nd = du + (axial if e < 4 else diagonal) * 0.5 * (w[u] + w[v])
            if nd < dist[v]:
                dist[v] = nd
                heapq.heappush(heap, (nd, v))


@jit
def _dijkstra(  # pragma: no cover - compiled
    ok: NDArray[np.bool_],
    w: Array,
    nx: int,
    ny: int,
    sources: NDArray[np.int64],
    axial: float,
    diagonal: float,
    dist: Array,
) -> None:
    """Dijkstra from ``sources`` into ``dist`` (filled with inf), the same distances as
    ``_dijkstra_python`` by a bucket queue (Dial's): buckets a little narrower than the
    cheapest step (a weight is at least 1), so no two cells of one bucket can improve each
    other and a bucket's cells are final in any order; a ring of buckets as long as the
    dearest step reaches, each a linked list of entries (stale ones skipped)."""
    n = nx * ny
    width = axial * (1.0 - 1e-9)
    dearest = diagonal * np.max(w)
    ring = int(dearest / width) + 2
    head = np.full(ring, -1, dtype=np.int64)
    cap = 8 * n + len(sources) + 1
    entry_cell = np.empty(cap, dtype=np.int64)
    entry_next = np.empty(cap, dtype=np.int64)
    used = 0
    live = 0
    done = np.zeros(n, dtype=np.bool_)
    for s in sources:
        if dist[s] == 0.0:
            continue
        dist[s] = 0.0
        entry_cell[used], entry_next[used] = s, head[0]
        head[0] = used
        used += 1
        live += 1
    current = 0
    while live > 0:
        b = current % ring
        while head[b] >= 0:
            e = head[b]
            head[b] = entry_next[e]
            live -= 1
            u = entry_cell[e]
            if done[u] or int(dist[u] / width) != current:
                continue  # settled already, or moved to an earlier bucket since
            done[u] = True
            if not ok[u]:
                continue
            ui, uj = u // ny, u % ny
            du = dist[u]
            for k in range(8):
                vi = ui + (1, -1, 0, 0, 1, 1, -1, -1)[k]
                vj = uj + (0, 0, 1, -1, 1, -1, 1, -1)[k]
                if vi < 0 or vi >= nx or vj < 0 or vj >= ny:
                    continue
                v = vi * ny + vj
                if done[v] or not ok[v]:
                    continue
                nd = du + (axial if k < 4 else diagonal) * 0.5 * (w[u] + w[v])
                if nd < dist[v]:
                    dist[v] = nd
                    t = int(nd / width) % ring
                    entry_cell[used], entry_next[used] = v, head[t]
                    head[t] = used
                    used += 1
                    live += 1
        current += 1


class CostHeuristic(Heuristic):  # type: ignore[misc]
    """The obstacle heuristic of a leg for pyperplan's searches and the cost search:
    ``max(0, map - reach)`` at the state's cell (``reach``: how far the centroid stays from
    the goal with the head on it); 0 once the goal is visited.

    With ``align``, the cheapest of leading with the head, a side or the tail along the map's
    way (its steepest descent): the turn onto it (its length and, where the cell's risk
    holds, what sweeping the turn's cells blind risks) plus, for a side or the tail, the
    reverse penalty over the rest of the way (the motions' ``tail_lead``). Without it a search
    from a body facing away from its goal meets every turn's and every reversed metre's cost
    in g only, after expanding every state it could reach more cheaply.

    ``values`` (and ``way``, ``risk``) cover the grid, flat in row order."""

    def __init__(
        self,
        task: Any,
        values: Array,
        reach: float,
        align: tuple[Array, float, float, float, float] | None = None,
    ) -> None:
        self.task, self.reach = task, reach
        self.values = np.ascontiguousarray(values, dtype=np.float64).ravel()
        grid = task.grid
        self.dims = np.array([grid.nx, grid.ny, grid.settings.orientations], dtype=np.int64)
        if align is None:
            self.risk = np.zeros(0)
            turn_length = cells_per_rad = contact = reverse = fill = 0.0
        else:
            risk, turn_length, cells_per_rad, contact, reverse = align
            self.risk = np.ascontiguousarray(risk, dtype=np.float64).ravel()
            fill = way_fill(self.values)
        self.hf = np.array(
            [grid.settings.step, reach, turn_length, cells_per_rad, contact, reverse, fill]
        )

    def __call__(self, node: Any) -> float:
        state = node.state
        if type(state) is LatticeState:  # the search's own states: no scan for the facts
            if state.visited:
                return 0.0
            number = state.number
        else:
            if self.task.goal_fact in state:
                return 0.0
            found = self.task.at(state)
            if found is None:
                return math.inf
            number = found
        return float(state_heuristic(number, self.dims, self.hf, self.values, self.risk))


def way_fill(distances: Array) -> float:
    """What a cut-off cell reads as when the way is taken: just beyond the farthest reached."""
    finite = distances[np.isfinite(distances)]
    return float(np.max(finite, initial=0.0)) + 1.0


def way_of(distances: Array) -> Array:
    """Per cell, the direction (radians) a map's way leads: its steepest descent (cells cut off
    read as ``way_fill``). The reference ``state_heuristic`` is held to: it takes one cell's
    way where it needs it (most cells' never are)."""
    finite = np.isfinite(distances)
    filled = np.where(finite, distances, way_fill(distances))
    gx, gy = np.gradient(filled)
    out: Array = np.arctan2(-gy, -gx)
    return out


@jit
def _filled(values: Array, cell: int, fill: float) -> float:  # pragma: no cover - compiled
    v = values[cell]
    return float(v) if v < math.inf else fill


@jit
def way_at(  # pragma: no cover - compiled
    values: Array, nx: int, ny: int, i: int, j: int, fill: float
) -> float:
    """``way_of(values.reshape(nx, ny))[i, j]``, from the cell's neighbours alone: numpy's
    gradient (central differences inside, one-sided at the edges) and arctan2, the same
    operations on the same floats (numpy's arctan2 over a whole array may take SIMD code that
    rounds one unit in the last place the other way)."""
    gx = gy = 0.0
    if nx > 1:
        if i == 0:
            gx = _filled(values, ny + j, fill) - _filled(values, j, fill)
        elif i == nx - 1:
            gx = _filled(values, i * ny + j, fill) - _filled(values, (i - 1) * ny + j, fill)
        else:
            gx = (
                _filled(values, (i + 1) * ny + j, fill) - _filled(values, (i - 1) * ny + j, fill)
            ) / 2.0
    if ny > 1:
        row = i * ny
        if j == 0:
            gy = _filled(values, row + 1, fill) - _filled(values, row, fill)
        elif j == ny - 1:
            gy = _filled(values, row + j, fill) - _filled(values, row + j - 1, fill)
        else:
            gy = (_filled(values, row + j + 1, fill) - _filled(values, row + j - 1, fill)) / 2.0
    return float(math.atan2(-gy, -gx))


@jit
def state_heuristic(  # pragma: no cover - compiled
    number: int,
    dims: NDArray[np.int64],
    hf: Array,
    values: Array,
    risk: Array,
) -> float:
    """A (not visited) state's heuristic value. ``dims``: nx, ny, K; ``hf``: turn step,
    reach, and for the alignment term (``risk`` given) the turn's metres per radian, its blind
    cells per radian, the contact cost, the reverse penalty and what a cut-off cell reads as
    when the way is taken (``way_fill``); ``values``, ``risk``: over the grid, flat."""
    nx, ny = dims[0], dims[1]
    rest, j = number // ny, number % ny
    k, i = rest // nx, rest % nx
    cell = i * ny + j
    d = values[cell]
    if not d < math.inf:
        return math.inf
    h = max(0.0, d - hf[1])
    if risk.shape[0] > 0 and h > 0.0:
        # e(ψ) points to the tail: the tail leads along ψ, the head along ψ + π, a side along
        # ψ ± π/2, so one angle gives all three turns onto the way
        way = way_at(values, nx, ny, i, j, hf[6])
        tail = abs(_remainder(k * hf[0] - way, 2 * math.pi))
        head, side = math.pi - tail, abs(0.5 * math.pi - tail)
        r = risk[cell]
        lead = _turn_cost(head, hf, r)
        # A turn's cost grows with its angle (risk is a log-probability, <= 0) and the reverse
        # penalty is >= 0: a lead turning further than a cheaper-penalised one cannot be least.
        if side < head:
            lead = min(lead, _turn_cost(side, hf, r) + 0.5 * hf[5] * h)
        if tail < head and tail < side:
            lead = min(lead, _turn_cost(tail, hf, r) + hf[5] * h)
        h += lead
    return float(h)


@jit
def _turn_cost(turn: float, hf: Array, risk: float) -> float:  # pragma: no cover - compiled
    """What turning ``turn`` radians in place costs at least: its length and the contacts its
    blind sweep risks (``hf``: see ``state_heuristic``)."""
    return float(hf[2] * turn + hf[4] * (1.0 - math.exp(hf[3] * turn * risk)))


@jit
def _remainder(x: float, y: float) -> float:  # pragma: no cover - compiled
    """CPython's ``math.remainder`` for finite ``x`` and ``y != 0`` (every step exact)."""
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

"""A compiled, pyperplan-compatible greedy best-first search over the lattice: the same plans
as pyperplan's ``greedy_best_first_search`` with the lattice heuristics, at a fraction of the
cost per expansion.

``search(task, heuristic)`` is called like pyperplan's search and returns the plan's operators
(or ``None``), raising ``SearchStopped`` when the budget, the deadline or a cancellation stops
it, with the heuristic's ``best`` (the most promising node seen, for a partial plan) set as
pyperplan's run would leave it. The loop itself is compiled (domain/lattice_search_kernel.py);
it runs when ``applies``: kernels on (``SCREWSNAKE_KERNELS``), the lattice or rejoin heuristic,
and a clearance with a compiled form (domain/grid_clearance.py). Everything else keeps
pyperplan's own search. What the PDDL export reads (``task.edges``, ``task.near``) is filled
from the expanded states when first read.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pyperplan.task import Operator

from domain import lattice_search_kernel as kernel
from domain.grid_clearance import ClearanceGrids, grids_of, has_grids
from domain.lattice import MotionTable
from domain.lattice_heuristic import LatticeHeuristic
from domain.lattice_store import Store
from domain.lattice_task import LatticeTask
from domain.occupancy_kernel import AVAILABLE
from domain.pyperplan_adapter import stop_if_due
from sim.robot import Array

CHUNK = 256  # expansions between checks of the deadline and the cancel flag
FIRST_NODES = 8192  # room for search nodes at first (doubled when full)
MAX_MOTIONS = 62  # motions per state a bitmask holds
_NO_BUDGET = 2**62


@dataclass(frozen=True)
class KernelTable:
    """A motion table as the kernel reads it (per bin, padded to the longest bin): each bin's
    distinct sample points (``ux``, ``uy``), each sample's row among them, the clearance each
    sample needs with the margin, where each motion's samples start and end."""

    ux: Array
    uy: Array
    inverse: NDArray[np.int64]
    needs: Array
    segments: NDArray[np.int64]
    deltas: NDArray[np.int64]
    cell_reach: NDArray[np.int64]
    n_unique: NDArray[np.int64]
    open_need: float


_TABLES: dict[tuple[int, float], tuple[MotionTable, KernelTable]] = {}
TABLES_KEPT = 16


def kernel_table(table: MotionTable, margin: float) -> KernelTable:
    """The kernel's form of ``table`` for motions keeping ``margin`` (made once per table)."""
    key = (id(table), margin)
    got = _TABLES.get(key)
    if got is not None and got[0] is table:
        return got[1]
    K, M = table.deltas.shape[:2]
    distinct = [table.distinct(k) for k in range(K)]
    n_unique = max(len(u) for u, _ in distinct)
    n_points = max(len(p) for p in table.points)
    ux, uy = np.zeros((K, n_unique)), np.zeros((K, n_unique))
    inverse = np.zeros((K, n_points), dtype=np.int64)
    needs = np.zeros((K, n_points))
    segments = np.zeros((K, M + 1), dtype=np.int64)
    for k, (unique, inv) in enumerate(distinct):
        ux[k, : len(unique)], uy[k, : len(unique)] = unique[:, 0], unique[:, 1]
        inverse[k, : len(inv)] = inv
        needs[k, : len(inv)] = table.needs[k] + margin  # as LatticeTask's per-bin needs
        segments[k, :M], segments[k, M] = table.segments[k], len(table.points[k])
    out = KernelTable(
        ux,
        uy,
        inverse,
        needs,
        segments,
        np.ascontiguousarray(table.deltas, dtype=np.int64),
        np.asarray(table.cell_reach, dtype=np.int64),
        np.array([len(u) for u, _ in distinct], dtype=np.int64),
        table.open_clearance + margin,
    )
    if len(_TABLES) >= TABLES_KEPT:
        _TABLES.clear()
    _TABLES[key] = (table, out)
    return out


def applies(task: LatticeTask, heuristic: Any) -> bool:
    """Whether the compiled search can run this task with this heuristic (else pyperplan's)."""
    from domain.lattice_repair import RejoinHeuristic, RejoinTask  # (it imports this module)

    # Exactly these types: a subclass may hand out other successors or heuristic values.
    return (
        AVAILABLE
        and (type(task), type(heuristic))
        in ((LatticeTask, LatticeHeuristic), (RejoinTask, RejoinHeuristic))
        and len(task.table.motions) <= MAX_MOTIONS
        and has_grids(task.clearance)
    )


class _Path:
    """A node of the compiled search as pyperplan's ``SearchNode`` is read: its path (built
    when asked for: only a partial plan reads it)."""

    def __init__(self, search: _Search, task: LatticeTask, node: int) -> None:
        self._search, self._task, self._node = search, task, node

    def extract_solution(self) -> list[Operator]:
        return self._search.operators(self._task, self._node)


_GROWN = [
    "node_state",
    "node_parent",
    "node_g",
    "node_op",
    "hh",
    "ht",
    "hn",
    "exp_number",
    "exp_bits",
    "exp_near",
]


class _Search:
    """The arrays of one search, grown as it goes."""

    def __init__(self, capacity: int) -> None:
        self.node_state = np.empty(capacity, dtype=np.int64)
        self.node_parent = np.empty(capacity, dtype=np.int64)
        self.node_g = np.empty(capacity, dtype=np.int64)
        self.node_op = np.empty(capacity, dtype=np.int64)
        self.hh = np.empty(capacity)
        self.ht = np.empty(capacity, dtype=np.int64)
        self.hn = np.empty(capacity, dtype=np.int64)
        self.exp_number = np.empty(capacity // 8, dtype=np.int64)
        self.exp_bits = np.empty(capacity // 8, dtype=np.int64)
        self.exp_near = np.empty(capacity // 8, dtype=np.bool_)
        self.count = np.zeros(kernel.COUNTERS, dtype=np.int64)
        self.best_h = np.array([math.inf])

    def full(self, more: int) -> bool:
        """Whether the nodes of one more expansion (``more`` successors) or its record would
        not fit."""
        count = self.count
        return bool(
            count[kernel.NODES] + more + 1 > len(self.node_state)
            or count[kernel.EXPANDED] >= len(self.exp_number)
        )

    def grow(self) -> None:
        """Twice the room for nodes and for expanded states."""
        for name in _GROWN:
            old = getattr(self, name)
            new = np.empty(2 * len(old), dtype=old.dtype)
            new[: len(old)] = old
            setattr(self, name, new)

    def operators(self, task: LatticeTask, node: int) -> list[Operator]:
        """The operators from the root to ``node`` (as pyperplan's ``extract_solution``)."""
        names = task.table.names
        out = []
        while node > 0:
            parent = int(self.node_parent[node])
            a, m = int(self.node_state[parent]), int(self.node_op[node])
            here = task.fact(a)
            if m < 0:
                name = f"(visit s{a} g{task.goal_index})"
                out.append(Operator(name, [here], [task.goal_fact], []))
            else:
                b = int(self.node_state[node])
                out.append(Operator(f"(move s{a} s{b} {names[m]})", [here], [task.fact(b)], [here]))
            node = parent
        out.reverse()
        return out


def _heuristic_inputs(task: LatticeTask, heuristic: Any) -> tuple[int, Array, tuple[Any, ...]]:
    """The kernel's heuristic: its kind, its numbers (turn step, step, largest turn) and arrays
    (base, way, narrow, the window's distances, target orientations)."""
    turn_step = task.grid.settings.step
    if isinstance(heuristic, LatticeHeuristic):
        arrays = (
            np.ascontiguousarray(heuristic.base, dtype=np.float64),
            np.ascontiguousarray(heuristic.way, dtype=np.float64),
            np.ascontiguousarray(heuristic.narrow, dtype=np.bool_),
            np.zeros((1, 1)),
            np.zeros(0, dtype=np.int64),
        )
        return kernel.LATTICE, np.array([turn_step, 1.0, 1.0]), arrays
    empty = np.zeros(0)
    dist = np.array(heuristic.distances, dtype=np.float64).reshape(len(heuristic.distances), -1)
    arrays = (empty, empty, np.zeros(0, dtype=np.bool_), dist, np.array(heuristic.ks, np.int64))
    return kernel.REJOIN, np.array([turn_step, heuristic.step, heuristic.turn]), arrays


def state_inputs(task: LatticeTask, kt: KernelTable) -> tuple[Array, Array]:
    """What the kernels read to place a state and shortcut open space: ``gf`` (grid xmin,
    ymin, resolution, open clearance + margin) and the clearance at the cell centres (empty
    when the task has none: the kernels interpolate)."""
    b = task.grid.bounds
    gf = np.array([b.xmin, b.ymin, task.grid.settings.resolution, kt.open_need])
    at_centres = task.at_centres if task.at_centres is not None else np.zeros(0)
    return gf, at_centres


def search(task: LatticeTask, heuristic: Any) -> list[Operator] | None:
    """pyperplan's ``greedy_best_first_search(task, heuristic)`` on the lattice, compiled (see
    the module's docstring; ``applies`` says when it can run)."""
    grids = grids_of(task.clearance)
    assert grids is not None, "a clearance with a compiled form (see applies())"
    grid, table = task.grid, task.table
    kt = kernel_table(table, task.margin)
    start_ok = task.free_mask(task.start_key)  # its own allowance, in Python as always
    start_bits = int(np.sum(np.left_shift(1, np.flatnonzero(start_ok)), dtype=np.int64))
    window = task.window or (slice(0, grid.nx), slice(0, grid.ny))
    (wi, wj), K = window, grid.settings.orientations
    dims = np.array([grid.nx, grid.ny, K, wi.start, wj.start, wi.stop, wj.stop], dtype=np.int64)
    gf, at_centres = state_inputs(task, kt)
    world = _world_inputs(grids)
    kind, hf, (base, way, narrow, window_dist, ks) = _heuristic_inputs(task, heuristic)
    cache = task.cache
    use_cache = cache is not None
    store = cache.compiled_free() if cache is not None else Store()
    cost = Store(FIRST_NODES)
    s = _Search(FIRST_NODES)
    start = task.start_number
    budget = int(task.budget) if math.isfinite(task.budget) else _NO_BUDGET
    near_states = task.near_states()
    try:
        while True:
            stop_if_due(task.cancel, task.deadline)
            status = kernel.run(
                CHUNK, budget, start, start_bits, near_states, dims, gf, at_centres, *world,
                kt.ux, kt.uy, kt.inverse, kt.needs, kt.segments, kt.deltas, kt.cell_reach,
                kt.n_unique,
                task.motion_targets, kind, hf, base, way, narrow, window_dist, ks, store.keys, store.values,
                store.size, use_cache, cost.keys, cost.values, cost.size, s.node_state, s.node_parent, s.node_g, s.node_op, s.hh, s.ht, s.hn,
                s.count, s.best_h, s.exp_number, s.exp_bits, s.exp_near,
            )  # fmt: skip
            if status == kernel.NEED_ROOM:
                n_motions = len(table.motions)
                if s.full(n_motions):
                    s.grow()
                cost.room(n_motions + 2)
                store.room(1)
            elif status == kernel.OVER_BUDGET:
                stop_if_due(task.cancel, task.deadline, True)
            elif status == kernel.SOLVED:
                return s.operators(task, int(s.count[kernel.GOAL]))
            elif status == kernel.EXHAUSTED:
                return None
    finally:
        task.expansions = int(s.count[kernel.EXPANSIONS])
        n = int(s.count[kernel.EXPANDED])
        task.expanded(s.exp_number[:n].copy(), s.exp_bits[:n].copy(), s.exp_near[:n].copy())
        if isinstance(heuristic, LatticeHeuristic):
            best = int(s.count[kernel.BEST])
            heuristic.best = (float(s.best_h[0]), _Path(s, task, best))


def _world_inputs(grids: ClearanceGrids) -> tuple[Array, Array]:
    return grids.values, grids.geometry

"""One leg of a plan as a pyperplan task whose successors, with their costs, are made by state.

pyperplan's searches only ask a task for its initial state, its goal test and the successors of
a state, so the lattice is never grounded up front: a state ``(at s)`` gets one ``(move s s'
p)`` operator per library primitive ``p`` valid from ``s``, carrying the motion's cost
(``costs``), and ``(visit s g)`` (cost 0) where the head is on goal ``g``. pyperplan's own
searches read the operators as unit-cost steps; the project's cost search reads ``cost``
(``domain.navigation.search``). Every operator handed out is remembered, so the part of the
lattice a search saw can be exported as PDDL with ``:action-costs``.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pyperplan.task import Operator, Task

from domain.navigation.lattice.cache import MotionCache, Rows
from domain.navigation.lattice.costs import (
    CostInputs,
    KernelTable,
    lethal_costs,
    risk_costs,
    start_costs,
    state_costs,
)
from domain.navigation.lattice.grid import Key, LatticeGrid
from domain.navigation.lattice.motions import MotionTable
from domain.navigation.lattice.states import LatticeState, StatePool
from domain.navigation.lattice.store import put, slot
from domain.pyperplan_adapter import CancelFlag, Fact, stop_if_due

Edge = tuple[int, str, float]  # next state, primitive's PDDL name, cost (m)
_EMPTY = np.zeros((1, 1))
_RELEASED = CostInputs(
    1, 1, np.zeros(4), _EMPTY, np.zeros(7), _EMPTY, _EMPTY, np.ones((1, 1), bool), np.zeros(5)
)


def state_name(number: int) -> str:
    return f"s{number}"


class CostOperator(Operator):  # type: ignore[misc]
    """A pyperplan operator with a cost in metres (pyperplan's searches ignore it)."""

    cost: float

    @classmethod
    def of(
        cls,
        name: str,
        pre: frozenset[Fact],
        add: frozenset[Fact],
        delete: frozenset[Fact],
        cost: float,
    ) -> CostOperator:
        """From ready frozensets (``Operator.__init__`` copies each into a new one: measurable
        when a search builds twenty per expansion)."""
        op = cls.__new__(cls)
        op.name, op.preconditions, op.add_effects, op.del_effects = name, pre, add, delete
        op.cost = cost
        return op


class LatticeTask(Task):  # type: ignore[misc]
    """One leg: from ``start`` to the head on ``goal`` (x, y within ``reach``). ``kt`` is the
    motions' table at the margin, ``kt_start`` the start's own (``KernelTable.bin`` of its bin:
    ``Planner.start_table``)."""

    def __init__(
        self,
        grid: LatticeGrid,
        table: MotionTable,
        inputs: CostInputs,
        kt: KernelTable,
        kt_start: KernelTable,
        start: Key,
        goal: tuple[float, float],
        reach: float,
        goal_index: int = 0,
        states: StatePool | None = None,
        cache: MotionCache | None = None,
    ) -> None:
        self.grid, self.table, self.inputs = grid, table, inputs
        self.kt, self.kt_start = kt, kt_start
        self.goal, self.reach = goal, reach
        self.start_key = start
        self.start_number = grid.encode(start)
        self.goal_fact = Fact(f"(visited g{goal_index})", grid.size + goal_index)
        self.goal_index = goal_index
        self.deadline = math.inf
        self.budget = math.inf  # expansions before pyperplan's searches stop (deterministic)
        self.cancel: CancelFlag | None = None
        self.expansions = 0
        self.states = states if states is not None else StatePool()
        self.cache = cache
        self._edges: dict[int, list[Edge]] = {}
        self._near: set[int] = set()
        # States a compiled search expanded with their valid motions and costs: ``edges`` and
        # ``near`` are filled from them when first read.
        self._pending: list[tuple[NDArray[np.int64], NDArray[np.int64], Any, Any]] = []
        self._size = grid.size
        self._start_costs: tuple[int, NDArray[np.float64]] | None = None
        self._near_states: NDArray[np.int64] | None = None
        # Per bin and motion: the next state's number less the cell's (i * ny + j), as
        # ``encode`` numbers them: (k' * nx + i + di) * ny + j + dj.
        K, d = grid.settings.orientations, table.deltas
        turned = (np.arange(K)[:, None] + d[..., 2]) % K
        self._targets = turned * (grid.nx * grid.ny) + d[..., 0] * grid.ny + d[..., 1]
        start_fact = self.fact(self.start_number)
        super().__init__(
            "lattice",
            {start_fact, self.goal_fact},
            frozenset([start_fact]),  # a plain one: pyperplan's Operator.apply asserts the type
            frozenset([self.goal_fact]),
            [],
        )

    def release(self) -> None:
        """Let go of what only searching reads (the world's grids, the motion cache), keeping
        what ``edges`` and ``near`` are filled from: a finished leg kept for its PDDL problem."""
        self._fill()
        self.inputs = _RELEASED
        self.cache, self.cancel = None, None

    @property
    def motion_targets(self) -> NDArray[np.int64]:
        """Per bin and motion: the next state's number less the cell's (see ``__init__``)."""
        out: NDArray[np.int64] = self._targets
        return out

    # -- what searches saw (the PDDL export) --------------------------------------------------
    @property
    def edges(self) -> dict[int, list[Edge]]:
        """Every successor (next state, primitive's PDDL name, cost) of every state expanded so
        far, in the order they were handed out."""
        self._fill()
        return self._edges

    @property
    def near(self) -> set[int]:
        """The expanded states where the head is on the goal (a visit leaves them)."""
        self._fill()
        return self._near

    def expanded(
        self,
        numbers: NDArray[np.int64],
        bits: NDArray[np.int64],
        costs: NDArray[np.float64],
        near: NDArray[np.bool_],
    ) -> None:
        """Record the states a compiled search expanded, in order, with their valid motions
        (bit ``m``: motion ``m``), their costs and whether each is near the goal."""
        self._pending.append((numbers, bits, costs, near))

    def keep_for_export(self, plan_states: Collection[int], limit: int) -> None:
        """Keep of what the search saw only what the PDDL export lists: the first ``limit``
        states expanded (in the search's order) and ``plan_states`` (the plan's own, so the
        plan solves the problem), with their successors."""
        if sum(len(chunk[0]) for chunk in self._pending) > limit:
            wanted = np.fromiter(plan_states, dtype=np.int64)
            kept, first = [], limit
            for numbers, bits, costs, near in self._pending:
                keep = np.arange(numbers.size) < first
                keep |= np.isin(numbers, wanted)
                first = max(0, first - numbers.size)
                kept.append((numbers[keep], bits[keep], costs[keep], near[keep]))
            self._pending = kept
        if len(self._edges) > limit:
            edges = {
                number: out
                for n, (number, out) in enumerate(self._edges.items())
                if n < limit or number in plan_states
            }
            self._edges = edges
            self._near &= set(edges)

    def _fill(self) -> None:
        pending, self._pending = self._pending, []
        for numbers, bits, costs, near in pending:
            self._near.update(numbers[near].tolist())
            for n, number in enumerate(numbers.tolist()):
                if number not in self._edges:
                    self._edges[number] = self._edge_list(number, int(bits[n]), costs[n])

    def _edge_list(self, number: int, bits: int, costs: NDArray[np.float64]) -> list[Edge]:
        k, cell = divmod(number, self.grid.nx * self.grid.ny)
        out = []
        for m in range(len(self.table.motions)):
            if not (bits >> m) & 1:
                continue
            b = int(self._targets[k, m]) + cell
            if b == number:
                continue
            out.append((b, self.table.names[m], float(costs[m])))
        return out

    # -- states -------------------------------------------------------------------------------
    def fact(self, number: int) -> Fact:
        return self.states.fact(number)

    def at(self, state: frozenset[Fact]) -> int | None:
        if type(state) is LatticeState:
            return state.number
        size = self._size
        for f in state:
            if f.number < size:
                return int(f.number)
        return None

    def goal_reached(self, state: frozenset[Fact]) -> bool:
        if type(state) is LatticeState:
            return state.visited
        return bool(self.goals <= state)

    def is_near(self, key: Key) -> bool:
        i, j, k = key
        dx, dy = self.table.heads[k]
        cx, cy = self.grid.centre_xy(i, j)
        return math.hypot(cx + dx - self.goal[0], cy + dy - self.goal[1]) <= self.reach

    def near_states(self) -> NDArray[np.int64]:
        """Every state where the head is on the goal (``is_near``), sorted (made once: the
        search and both walks of ``search.reach`` read it)."""
        if self._near_states is None:
            self._near_states = near_goal_states(self)
        return self._near_states

    # -- motions ------------------------------------------------------------------------------
    def start_costs(self) -> tuple[int, NDArray[np.float64]]:
        """The start's valid motions (bitmask) and their costs, by its own table."""
        if self._start_costs is None:
            self._start_costs = start_costs(self.start_number, self.inputs, self.kt_start)
        return self._start_costs

    def valid(self, number: int) -> tuple[int, NDArray[np.float64]]:
        """The valid motions of a state (bitmask) and their costs, read from the cache or
        evaluated (the start with its own margin, never cached)."""
        if number == self.start_number:
            return self.start_costs()
        cache = self.cache
        if cache is None:
            return state_costs(number, self.inputs, self.kt)
        rows = cache.lethal
        at = slot(rows.index.keys, number)
        if rows.index.keys[at] == number:
            row = int(rows.index.values[at])
            bits, base = int(rows.ints[row]), rows.floats[row]
        else:
            bits, base = lethal_costs(number, self.inputs, self.kt)
            _keep(rows, number, bits, base)
        rows = cache.risk
        at = slot(rows.index.keys, number)
        if rows.index.keys[at] == number:
            extra = rows.floats[int(rows.index.values[at])]
        else:
            extra = risk_costs(number, self.inputs, self.kt)
            _keep(rows, number, 0, extra)
        return bits, base + extra

    def valid_motions(self, key: Key) -> list[tuple[Key, int, float]]:
        """The motions valid from ``key``: where each leads, its index and its cost."""
        i, j, k = key
        bits, costs = self.valid(self.grid.encode(key))
        d = self.table.deltas[k]
        K = self.grid.settings.orientations
        out = []
        for m in range(len(self.table.motions)):
            if (bits >> m) & 1:
                nxt = (int(i + d[m, 0]), int(j + d[m, 1]), int((k + d[m, 2]) % K))
                out.append((nxt, m, float(costs[m])))
        return out

    # -- pyperplan's Task interface -----------------------------------------------------------
    def get_successor_states(
        self, state: frozenset[Fact]
    ) -> list[tuple[Operator, frozenset[Fact]]]:
        self.expansions += 1
        stop_if_due(self.cancel, self.deadline, self.expansions > self.budget)
        number = self.at(state)
        if number is None or self.goal_reached(state):
            return []
        bits, costs = self.valid(number)
        k, cell = divmod(number, self.grid.nx * self.grid.ny)
        pool, names = self.states, self.table.names
        here = pool.fact(number)
        pre = frozenset([here])  # shared by every move out of here (precondition and delete)
        out: list[tuple[Operator, frozenset[Fact]]] = []
        if self.is_near(self.grid.decode(number)):
            self._near.add(number)
            op = CostOperator.of(
                f"(visit {state_name(number)} g{self.goal_index})",
                pre,
                frozenset([self.goal_fact]),
                frozenset(),
                0.0,
            )
            out.append((op, LatticeState.of((here, self.goal_fact), number, True)))
        edges: list[Edge] = []
        for m in range(len(names)):
            if not (bits >> m) & 1:
                continue
            b = int(self._targets[k, m]) + cell
            if b == number:
                continue
            after = pool.state(b)
            cost = float(costs[m])
            name = f"(move {state_name(number)} {state_name(b)} {names[m]})"
            out.append((CostOperator.of(name, pre, after, pre, cost), after))
            edges.append((b, names[m], cost))
        self._edges.setdefault(number, edges)
        return out

    def ground_all(self) -> None:
        """Enumerate the whole reachable lattice into ``operators`` (for pyperplan's own
        heuristics such as hFF, which need every operator); honours the deadline."""
        ops: dict[str, Operator] = {}
        frontier = [self.initial_state]
        seen = {self.start_number}
        while frontier:
            state = frontier.pop()
            for op, nxt in self.get_successor_states(state):
                ops.setdefault(op.name, op)
                n = self.at(nxt)
                if n is not None and n not in seen:
                    seen.add(n)
                    frontier.append(nxt)
        self.operators = sorted(ops.values(), key=lambda o: o.name)
        self.facts = {f for op in self.operators for f in (*op.preconditions, *op.add_effects)}
        self.facts |= set(self.initial_state) | {self.goal_fact}


def _keep(rows: Rows, number: int, value: int, floats: NDArray[np.float64]) -> None:
    rows.room(1)
    row = int(rows.used[0])
    rows.ints[row], rows.floats[row] = value, floats
    rows.used[0] += 1
    put(rows.index.keys, rows.index.values, rows.index.size, number, row)


def near_goal_states(task: LatticeTask) -> NDArray[np.int64]:
    """Every state where the head is on the task's goal (``is_near``), sorted: the cells round
    the goal, by the same arithmetic as ``is_near`` (numpy's ``hypot`` may differ from
    ``math.hypot`` in the last place, so states within a hair of the reach ask ``is_near``)."""
    grid, r, b = task.grid, task.grid.settings.resolution, task.grid.bounds
    gx, gy = task.goal
    heads = np.asarray(task.table.heads, dtype=np.float64)  # [K, 2]
    half = math.ceil(task.reach / r) + 2
    span = np.arange(-half, half + 1)
    # Per bin, the cells round the one whose head lies on the goal.
    ci = np.floor((gx - heads[:, 0] - b.xmin) / r).astype(np.int64)[:, None, None]
    cj = np.floor((gy - heads[:, 1] - b.ymin) / r).astype(np.int64)[:, None, None]
    i, j = ci + span[None, :, None], cj + span[None, None, :]  # [K, S, 1], [K, 1, S]
    x = b.xmin + (i + 0.5) * r + heads[:, 0, None, None]
    y = b.ymin + (j + 0.5) * r + heads[:, 1, None, None]
    d = np.hypot(x - gx, y - gy)  # [K, S, S]
    on = (i >= 0) & (i < grid.nx) & (j >= 0) & (j < grid.ny)
    near = on & (d <= task.reach)
    unsure = on & (np.abs(d - task.reach) <= 1e-12 * max(1.0, task.reach))
    for k, a, c in zip(*np.nonzero(unsure), strict=True):
        key = (int(ci[k, 0, 0] + span[a]), int(cj[k, 0, 0] + span[c]), int(k))
        near[k, a, c] = task.is_near(key)
    k, a, c = np.nonzero(near)
    numbers = (k * grid.nx + ci[k, 0, 0] + span[a]) * grid.ny + cj[k, 0, 0] + span[c]
    return np.sort(numbers.astype(np.int64))


def plan_states(task: LatticeTask, names: Sequence[str]) -> list[int]:
    """The states a plan's operators (names) pass through, from the start."""
    out = [task.start_number]
    for name in names:
        verb, *args = name.strip("()").split()
        if verb == "move":
            out.append(int(args[1][1:]))
    return out

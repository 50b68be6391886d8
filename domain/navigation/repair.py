"""Repairs the plan being run around a local change instead of planning the whole way again.

A replan after a local change (an obstacle the range sensors found ahead) mostly finds the plan
still valid except near the change. The repair checks the remaining moves against the new
lethal layer, and if some are blocked, searches a detour with the same cost search from a state
before the first blocked move (or from the robot's state, if it is off the plan) to any of the
plan's states a few moves after the last blocked one, inside a window of cells around them. Its
heuristic is the obstacle heuristic of the window alone (to the nearest target cell, plus the
turn to the nearest target heading), so a repair costs what the change's neighbourhood costs,
not what the arena does (the purpose of D* Lite / LPA*). Whatever the repair cannot do (a window
too large, a goal visit inside the blocked part, no detour within its budget) is left to a full
plan, which also decides unreachability.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from domain.goal_order import LegGoal
from domain.navigation import search as searches
from domain.navigation.lattice.cache import MotionCache
from domain.navigation.lattice.costs import CostInputs
from domain.navigation.lattice.grid import Key
from domain.navigation.lattice.pddl import LatticeGraph
from domain.navigation.lattice.task import LatticeTask
from domain.navigation.plan import Plan, PlanAction, PlanRequest
from domain.navigation.search.heuristic import CostHeuristic, step_weights, weighted_geodesic
from domain.pyperplan_adapter import SearchStopped

if TYPE_CHECKING:
    from domain.navigation.planner import Planner

WINDOW_BLOCK = 16  # cells: window sides are multiples of this (few sizes of window)


def leg_reach(goal: LegGoal) -> float:
    """How close the tracked point must come to a goal for the plan to visit it."""
    return max(0.03, 0.6 * goal.tolerance)


@dataclass(frozen=True)
class PlanStep:
    """One remaining action of a plan, as the repair reads it."""

    action: PlanAction
    state: int  # lattice state number the action starts from
    after: int  # ... and where it leaves the robot (the same for a visit)
    motion: int | None  # motion index of a move
    label: str  # the move's primitive (PDDL name), or the visit's goal point (``g3``)

    @property
    def goal(self) -> int:
        """The goal index a visit visits."""
        return int(self.label[1:])


def plan_steps(actions: Sequence[PlanAction]) -> list[PlanStep]:
    """The actions with their lattice states."""
    out = []
    for a in actions:
        parts = a.pddl.strip("()").split()
        if a.name == "move" and a.motion is not None:
            out.append(PlanStep(a, int(parts[1][1:]), int(parts[2][1:]), a.motion, parts[3]))
        else:
            n = int(parts[1][1:])
            out.append(PlanStep(a, n, n, None, parts[2]))
    return out


class RejoinTask(LatticeTask):
    """A detour: from ``start`` to any of the lattice states ``targets`` within a window."""

    def __init__(self, *args: object, targets: Sequence[int], window: tuple[slice, slice]) -> None:
        self.targets = set(targets)
        super().__init__(*args)  # type: ignore[arg-type]
        self.window = window

    def is_near(self, key: Key) -> bool:
        return self.grid.encode(key) in self.targets

    def near_states(self) -> NDArray[np.int64]:
        return np.array(sorted(self.targets), dtype=np.int64)


class Repairer:
    """Repairs the plans of one planner (see the module's docstring)."""

    def __init__(self, planner: Planner) -> None:
        self.planner = planner

    def repair(
        self,
        request: PlanRequest,
        inputs: CostInputs,
        cache: MotionCache,
        start: Key,
        deadline: float,
    ) -> Plan | None:
        """The plan being run made valid again from the robot's state ``start``, or ``None``
        if a full plan is needed."""
        previous = request.previous
        if previous is None or previous.partial or not previous.actions:
            return None
        planner, grid = self.planner, self.planner.grid
        table = request.table
        policy = planner.settings.search
        steps = plan_steps(previous.actions)
        here = grid.encode(start)
        on = next(
            (n for n, s in enumerate(steps[: policy.repair_on_plan]) if s.state == here), None
        )
        steps = steps[on:] if on is not None else steps
        if not _visits_goals(steps, request.goals, request.ordered):
            return None  # the goals changed: a full plan orders them again
        moves = [n for n, s in enumerate(steps) if s.motion is not None]
        if not moves:
            return None
        probe = planner.task(
            table, inputs, cache, start, request.goals[0], True, deadline, request.cancel
        )
        valid = [
            bool((probe.valid(steps[n].state)[0] >> int(steps[n].motion or 0)) & 1) for n in moves
        ]
        bad = np.flatnonzero(~np.array(valid))
        if on is not None and bad.size == 0:
            actions = [s.action for s in steps]
            return self._plan(previous, actions, self._graph(start, actions, request.goals), 0)
        # The detour replaces steps[leave:rest]: from a state before the first blocked move
        # (or from the robot's own state, off the plan) to one of the states a little after
        # the last blocked move (``rest`` is the step the kept part starts with).
        leave = moves[max(0, int(bad[0]) - policy.repair_leave_before)] if on is not None else 0
        join = (int(bad[-1]) if bad.size else -1) + 1 + policy.repair_rejoin_after
        ends = [moves[q] for q in range(join, min(len(moves), join + policy.repair_rejoin_span))]
        if join + policy.repair_rejoin_span > len(moves):
            ends.append(moves[-1] + 1)  # the plan's last state (its final visits kept)
        if any(s.motion is None for s in steps[leave : ends[-1]]):
            return None  # a goal visit inside the part replaced: a full plan decides
        source = grid.decode(steps[leave].state) if on is not None else start
        at = {(steps[n].state if n < len(steps) else steps[-1].after): n for n in reversed(ends)}
        around = [source, *(grid.decode(s.state) for s in steps[leave : ends[-1]])]
        window = self._window([*around, *(grid.decode(t) for t in at)])
        if window is None:
            return None
        first = on is None or leave == 0
        kt, kt_start = planner.tables(table, source if first else None, inputs)
        task = RejoinTask(
            grid, table, inputs, kt, kt_start, source, (0.0, 0.0), 0.0, 0, planner.states,
            cache, targets=list(at), window=window,
        )  # fmt: skip
        task.deadline, task.cancel = deadline, request.cancel
        heuristic = self._heuristic(task, inputs, window)
        if heuristic is None:
            return None
        s = planner.settings.search
        try:
            found = searches.run(
                task, heuristic, searches.COST_SEARCH, s.weight, s.repair_expansions
            )
        except SearchStopped as stop:
            if stop.status == "cancelled":
                raise
            return None
        if found.status != "solved" or found.plan is None:
            return None
        found_actions, end = planner.actions_of(task, [op.name for op in found.plan], found.plan)
        detour = [a for a in found_actions if a.name == "move"]
        rest = at[grid.encode(end)]
        actions = [s.action for s in steps[:leave]] + detour + [s.action for s in steps[rest:]]
        graph = self._graph(start, actions, request.goals)
        for a, out in task.edges.items():
            for b, p, cost in out:
                graph.add(a, b, p, cost)
        graph.notes.append(
            f"repaired: a detour of {len(detour)} moves replaces {rest - leave} planned steps "
            f"({len(task.edges)} states expanded); the rest of the plan is kept"
        )
        return self._plan(previous, actions, graph, task.expansions)

    def _plan(
        self, previous: Plan, actions: list[PlanAction], graph: LatticeGraph, expansions: int
    ) -> Plan:
        order = [a.goal for a in actions if a.name == "visit" and a.goal is not None]
        out = Plan(actions, order, expansions, repaired=True, graph=graph, shape=previous.shape)
        return out

    def _heuristic(
        self, task: RejoinTask, inputs: CostInputs, window: tuple[slice, slice]
    ) -> CostHeuristic | None:
        """The window's obstacle heuristic to the nearest target (``None``: the start is cut
        off from every target inside the window)."""
        planner, grid = self.planner, self.planner.grid
        wi, wj = window
        at = np.ascontiguousarray(inputs.values[wi, wj], dtype=float)
        r = grid.settings.resolution
        ok = at >= task.table.centroid_need() - r * math.sqrt(0.5)
        cells = [grid.decode(t)[:2] for t in task.targets]
        local = [(i - wi.start, j - wj.start) for i, j in cells]
        for i, j in local:
            ok[i, j] = True
        si, sj, _ = task.start_key
        ii, jj = np.indices(ok.shape)
        ok |= np.hypot(ii + wi.start - si, jj + wj.start - sj) * r <= 0.15
        weights = step_weights(at.ravel(), planner.settings.margin, planner.settings.costs)
        dist = weighted_geodesic(ok, weights.reshape(ok.shape), local, r)
        if not math.isfinite(dist[si - wi.start, sj - wj.start]):
            return None
        headings = sorted({grid.decode(t)[2] for t in task.targets})
        return CostHeuristic(task, dist, window, 0.0, headings, task.table.turn_cost)

    def _window(self, keys: Sequence[Key]) -> tuple[slice, slice] | None:
        """The cells the detour may use: around ``keys``, padded; ``None`` if too large."""
        grid, s = self.planner.grid, self.planner.settings.search
        r = grid.settings.resolution
        pad = math.ceil(s.repair_pad / r)
        spans = []
        for axis, n in ((0, grid.nx), (1, grid.ny)):
            lo, hi = min(k[axis] for k in keys) - pad, max(k[axis] for k in keys) + pad + 1
            side = min(n, -(-(hi - lo) // WINDOW_BLOCK) * WINDOW_BLOCK)
            lo = min(max(0, lo - (side - (hi - lo)) // 2), n - side)
            spans.append(slice(lo, lo + side))
        if max(sp.stop - sp.start for sp in spans) * r > s.repair_window:
            return None
        return spans[0], spans[1]

    def _graph(
        self, start: Key, actions: Sequence[PlanAction], goals: Sequence[LegGoal]
    ) -> LatticeGraph:
        """The plan's own moves and visits as a lattice problem's graph."""
        grid = self.planner.grid
        graph = LatticeGraph(start, grid.encode(start))
        for step in plan_steps(actions):
            if step.motion is None:
                graph.near.add((step.state, step.goal))
            else:
                graph.add(step.state, step.after, step.label, step.action.cost)
        for g in goals:
            graph.goals.append((g.index, g.x, g.y, leg_reach(g)))
        return graph


def _visits_goals(steps: Sequence[PlanStep], goals: Sequence[LegGoal], ordered: bool) -> bool:
    """Whether the steps visit exactly ``goals`` (in their order if ``ordered``), each where the
    head is on it (a goal moved since is not)."""
    visits = [s for s in steps if s.motion is None]
    by_index = {g.index: g for g in goals}
    if len(visits) != len(goals) or {s.goal for s in visits} != set(by_index):
        return False
    if ordered and [s.goal for s in visits] != [g.index for g in goals]:
        return False
    return all(
        math.hypot(s.action.target[0] - by_index[s.goal].x, s.action.target[1] - by_index[s.goal].y)
        <= leg_reach(by_index[s.goal]) + 1e-9
        for s in visits
    )

"""Repairs the remaining plan around a local change instead of planning the whole way again.

A replan after a local change (an obstacle the range sensors found ahead) mostly finds the old
plan still good except near the change. The repair checks the remaining moves' swept
footprints against the new world model in one vectorised query, and if some are blocked,
searches a detour with pyperplan's search from a state before the first blocked move (or from
the robot's state, if it is off the plan) to any of the old plan's states a few moves after the
last blocked one, inside a window of cells around them. Its heuristic is a geodesic distance map of the window
alone, so a repair costs what the change's neighbourhood costs, not what the arena does (the
purpose of D* Lite / LPA*; here the search itself stays pyperplan's). Whatever the repair
cannot do (a window too large, a goal visit inside the blocked part, no detour within its
expansion budget) is left to a full plan, which also decides unreachability.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pyperplan.heuristics.heuristic_base import Heuristic
from pyperplan.search import greedy_best_first_search

from domain import lattice_search
from domain.goal_order import LegGoal
from domain.lattice import Key, LatticeGrid, MotionTable
from domain.lattice_cache import MotionCache, Moves
from domain.lattice_distances import centroid_need, window_distance_map
from domain.lattice_pddl import LatticeGraph
from domain.lattice_plan import LatticeAction
from domain.lattice_states import no_cycle_collection
from domain.lattice_task import Clearance, LatticeTask, start_allowance
from domain.pyperplan_adapter import CancelFlag, SearchStopped
from domain.touching import TouchAllowance
from sim.robot import Array

REJOIN_AFTER = 2  # moves past the last blocked one where a detour may join the old plan ...
REJOIN_SPAN = 10  # ... or at any of this many states after that (the search picks the nearest)
LEAVE_BEFORE = 3  # moves before the first blocked one where it leaves the old plan
ON_PLAN = 4  # the robot counts as on the plan if its state is one of the next this many
PAD = 0.8  # metres the search window reaches beyond the detour's ends and the blocked moves
WINDOW_BLOCK = 16  # cells: window sides are multiples of this
MAX_WINDOW = 8.0  # metres: a detour needing a larger window is left to a full plan
BUDGET = 100  # expansions before a repair gives up (a budget, not seconds: deterministic)


@dataclass(frozen=True)
class PlanStep:
    """One remaining action of a plan, as the repair reads it."""

    action: LatticeAction
    state: int  # lattice state number the action starts from
    after: int  # ... and where it leaves the robot (the same for a visit)
    motion: int | None  # motion index of a move
    label: str  # the move's primitive (PDDL name), or the visit's goal point (``g3``)

    @property
    def goal(self) -> int:
        """The goal index a visit visits."""
        return int(self.label[1:])


def plan_steps(grid: LatticeGrid, actions: Sequence[LatticeAction]) -> list[PlanStep] | None:
    """The actions with their lattice states (``None`` if they are not a lattice plan: a
    shape change, or a move without its motion)."""
    out = []
    for a in actions:
        parts = a.pddl.strip("()").split()
        if a.name == "move" and a.motion is not None:
            out.append(PlanStep(a, int(parts[1][1:]), int(parts[2][1:]), a.motion, parts[3]))
        elif a.name == "visit":
            n = int(parts[1][1:])
            out.append(PlanStep(a, n, n, None, parts[2]))
        else:
            return None
    return out


def moves_free(
    grid: LatticeGrid,
    table: MotionTable,
    clearance: Clearance,
    moves: Sequence[tuple[int, int]],
    margins: Sequence[float | TouchAllowance],
) -> NDArray[np.bool_]:
    """Whether each move ``(state number, motion index)`` keeps its margin clear along its
    swept footprint (a move out of where the robot touches something: its allowance's margins):
    one clearance query for all of them."""
    points, needs, owner = [], [], []
    for n, ((number, m), margin) in enumerate(zip(moves, margins, strict=True)):
        i, j, k = grid.decode(number)
        seg = table.segments[k]
        lo = int(seg[m])
        hi = int(seg[m + 1]) if m + 1 < len(seg) else len(table.points[k])
        at = grid.centre(i, j) + table.points[k][lo:hi]
        points.append(at)
        needs.append(
            table.needs[k][lo:hi]
            + (margin.at(at) if isinstance(margin, TouchAllowance) else margin)
        )
        owner.append(np.full(hi - lo, n))
    if not moves:
        return np.ones(0, dtype=bool)
    ok = clearance(np.concatenate(points)) >= np.concatenate(needs)
    bad = np.bincount(np.concatenate(owner)[~ok], minlength=len(moves))
    out: NDArray[np.bool_] = bad == 0
    return out


class RejoinTask(LatticeTask):
    """A detour: from ``start`` to any of the lattice states ``targets`` within a window."""

    window: tuple[slice, slice]

    def __init__(
        self,
        grid: LatticeGrid,
        table: MotionTable,
        clearance: Clearance,
        start: Key,
        targets: Sequence[int],
        window: tuple[slice, slice],
        margin: float,
        start_margin: float,
    ) -> None:
        self.targets, self.window = set(targets), window
        x, y = grid.centre(*grid.decode(targets[0])[:2])
        super().__init__(
            grid, table, clearance, start, (float(x), float(y)), 0.0, margin, start_margin
        )

    def is_near(self, key: Key) -> bool:
        return self.grid.encode(key) in self.targets

    def near_states(self) -> NDArray[np.int64]:
        return np.array(sorted(self.targets), dtype=np.int64)

    def moves_from(self, number: int) -> Moves:
        """The lattice's moves out of ``number`` that stay inside the window."""
        moves, edges = super().moves_from(number)
        (wi, wj), ny, plane = self.window, self.grid.ny, self.grid.nx * self.grid.ny
        inside = []
        for n, (b, _) in enumerate(edges):
            i, j = divmod(b % plane, ny)
            if wi.start <= i < wi.stop and wj.start <= j < wj.stop:
                inside.append(n)
        if len(inside) == len(edges):
            return moves, edges
        return [moves[n] for n in inside], [edges[n] for n in inside]


class RejoinHeuristic(Heuristic):  # type: ignore[misc]
    """Geodesic distance in the window to the nearest target cell, in moves of ``step``
    metres, plus the turns still needed to the nearest target orientation (in the library's
    largest turns)."""

    def __init__(self, task: RejoinTask, distances: Array, step: float, turn: float) -> None:
        self.task, self.step, self.turn = task, step, turn
        self.distances = distances.tolist()
        self.ks = sorted({task.grid.decode(t)[2] for t in task.targets})
        self.turn_step = task.grid.settings.step

    def __call__(self, node: Any) -> float:
        task = self.task
        if task.goal_reached(node.state):
            return 0.0
        number = task.at(node.state)
        if number is None:
            return math.inf
        i, j, k = task.grid.decode(number)
        d: float = self.distances[i - task.window[0].start][j - task.window[1].start]
        if not math.isfinite(d):
            return math.inf
        dk = min(abs(math.remainder((k - t) * self.turn_step, 2 * math.pi)) for t in self.ks)
        return d / self.step + dk / self.turn


@dataclass
class Repair:
    """A repaired plan: its actions and the lattice its problem lists."""

    actions: list[LatticeAction]
    graph: LatticeGraph
    expansions: int = 0

    @property
    def order(self) -> list[int]:
        """The goals in the order the plan visits them."""
        return [a.goal for a in self.actions if a.name == "visit" and a.goal is not None]


class PlanRepairer:
    """Repairs remaining plans on one lattice (see the module's docstring)."""

    def __init__(
        self,
        grid: LatticeGrid,
        margin: float,
        start_margin: float,
        search: Callable[..., Any],
        actions_of: Callable[
            [LatticeTask, MotionTable, list[str]], tuple[list[LatticeAction], Key]
        ],
        cache_of: Callable[[MotionTable, Hashable], MotionCache],
    ) -> None:
        self.grid, self.margin, self.start_margin = grid, margin, start_margin
        self.search, self.actions_of, self.cache_of = search, actions_of, cache_of

    def repair(
        self,
        table: MotionTable,
        clearance: Clearance,
        start: Key,
        goals: Sequence[LegGoal],
        previous: Sequence[LatticeAction],
        ordered: bool,
        deadline: float,
        cancel: CancelFlag | None,
        family: Hashable = None,
    ) -> Repair | None:
        """The remaining plan ``previous`` made free again from the robot's state ``start``,
        or ``None`` if a full plan is needed (``family``: the planner's motion cache to read,
        ``LatticePlanner.motion_cache``)."""
        steps = plan_steps(self.grid, previous)
        if not steps:
            return None
        here = self.grid.encode(start)
        on = next((n for n, s in enumerate(steps[:ON_PLAN]) if s.state == here), None)
        steps = steps[on:] if on is not None else steps
        if not self._visits_goals(steps, goals, ordered):
            return None  # the goals changed: a full plan orders them again
        moves = [n for n, s in enumerate(steps) if s.motion is not None]
        if not moves:
            return None
        # The robot may touch something where it stands: moves out of there keep less.
        allowance = start_allowance(self.grid, table, clearance, start, self.start_margin)
        margins: list[float | TouchAllowance] = [
            allowance if steps[n].state == here else self.margin for n in moves
        ]
        free = moves_free(
            self.grid,
            table,
            clearance,
            [(steps[n].state, int(steps[n].motion or 0)) for n in moves],
            margins,
        )
        bad = np.flatnonzero(~free)
        if on is not None and bad.size == 0:
            actions = [s.action for s in steps]
            return Repair(actions, self._graph(start, actions, goals))
        # The detour replaces steps[leave:rest]: from a state before the first blocked move
        # (or from the robot's own state, off the plan) to one of the states a little after
        # the last blocked move (``rest`` is the step the kept part starts with).
        leave = moves[max(0, int(bad[0]) - LEAVE_BEFORE)] if on is not None else 0
        join = (int(bad[-1]) if bad.size else -1) + 1 + REJOIN_AFTER
        ends = [moves[q] for q in range(join, min(len(moves), join + REJOIN_SPAN))]
        if join + REJOIN_SPAN > len(moves):
            ends.append(moves[-1] + 1)  # the plan's last state (its final visits kept)
        if any(s.motion is None for s in steps[leave : ends[-1]]):
            return None  # a goal visit inside the part replaced: a full plan decides
        source = self.grid.decode(steps[leave].state) if on is not None else start
        at = {(steps[n].state if n < len(steps) else steps[-1].after): n for n in reversed(ends)}
        around = [source, *(self.grid.decode(s.state) for s in steps[leave : ends[-1]])]
        window = self._window([*around, *(self.grid.decode(t) for t in at)])
        if window is None:
            return None
        first = on is None or leave == 0
        task = RejoinTask(
            self.grid,
            table,
            clearance,
            source,
            list(at),
            window,
            self.margin,
            self.start_margin if first else self.margin,
        )
        task.deadline, task.cancel, task.budget = deadline, cancel, BUDGET
        task.cache = self._cache(table, clearance, window, family)
        names = self._search(task, table, clearance)
        if names is None:
            return None
        found, end = self.actions_of(task, table, names)
        detour = [a for a in found if a.name == "move"]
        rest = at[self.grid.encode(end)]
        actions = [s.action for s in steps[:leave]] + detour + [s.action for s in steps[rest:]]
        graph = self._graph(start, actions, goals)
        for a, out in task.edges.items():
            graph.edges.update((a, b, p) for b, p in out)
        graph.notes.append(
            f"repaired: a detour of {len(detour)} moves replaces {rest - leave} planned steps "
            f"({len(task.edges)} states expanded); the rest of the plan is kept"
        )
        return Repair(actions, graph, task.expansions)

    @staticmethod
    def _visits_goals(steps: Sequence[PlanStep], goals: Sequence[LegGoal], ordered: bool) -> bool:
        """Whether the steps visit exactly ``goals`` (in their order if ``ordered``), each
        where the head is on it (a goal moved since is not)."""
        visits = [s for s in steps if s.motion is None]
        by_index = {g.index: g for g in goals}
        if len(visits) != len(goals) or {s.goal for s in visits} != set(by_index):
            return False
        if ordered and [s.goal for s in visits] != [g.index for g in goals]:
            return False
        return all(
            math.hypot(
                s.action.target[0] - by_index[s.goal].x, s.action.target[1] - by_index[s.goal].y
            )
            <= leg_reach(by_index[s.goal]) + 1e-9
            for s in visits
        )

    def _window(self, keys: Sequence[Key]) -> tuple[slice, slice] | None:
        """The cells the detour may use: around ``keys``, padded; ``None`` if too large."""
        r = self.grid.settings.resolution
        pad = math.ceil(PAD / r)
        # Sides rounded up to whole blocks: windows of few sizes reuse one graph topology.
        spans = []
        for axis, n in ((0, self.grid.nx), (1, self.grid.ny)):
            lo, hi = min(k[axis] for k in keys) - pad, max(k[axis] for k in keys) + pad + 1
            side = min(n, -(-(hi - lo) // WINDOW_BLOCK) * WINDOW_BLOCK)
            lo = min(max(0, lo - (side - (hi - lo)) // 2), n - side)
            spans.append(slice(lo, lo + side))
        if max(s.stop - s.start for s in spans) * r > MAX_WINDOW:
            return None
        return spans[0], spans[1]

    def _cache(
        self,
        table: MotionTable,
        clearance: Clearance,
        window: tuple[slice, slice],
        family: Hashable = None,
    ) -> MotionCache:
        """The shape's motion cache, refreshed around the window (a motion's reach beyond
        it: where a change could touch the motions of states in it)."""
        cache, grid = self.cache_of(table, family), self.grid
        pad = math.ceil(cache.reach / grid.settings.resolution) + 2
        wi, wj = window
        around = (
            slice(max(0, wi.start - pad), min(grid.nx, wi.stop + pad)),
            slice(max(0, wj.start - pad), min(grid.ny, wj.stop + pad)),
        )
        centres = grid.centres.reshape(grid.nx, grid.ny, 2)[around].reshape(-1, 2)
        cache.refresh_window(clearance(centres), around)
        return cache

    def _search(
        self, task: RejoinTask, table: MotionTable, clearance: Clearance
    ) -> list[str] | None:
        """pyperplan's search for the detour, guided by the window's distance map."""
        grid, (wi, wj) = self.grid, task.window
        centres = grid.centres.reshape(grid.nx, grid.ny, 2)[wi, wj].reshape(-1, 2)
        si, sj, _ = task.start_key
        cells = [grid.decode(t)[:2] for t in task.targets]
        dist = window_distance_map(
            grid, task.window, clearance(centres), cells, centroid_need(table), (si, sj)
        )
        if not math.isfinite(dist[si - wi.start, sj - wj.start]):
            return None
        heuristic = RejoinHeuristic(task, dist, table.longest_step, table.largest_turn)
        try:
            if self.search is greedy_best_first_search and lattice_search.applies(task, heuristic):
                plan = lattice_search.search(task, heuristic)  # the same plan, compiled
            else:
                with no_cycle_collection(), task.search_reached(self.search):
                    plan = self.search(task, heuristic)
        except SearchStopped:
            return None
        return None if plan is None else [op.name for op in plan]

    def _graph(
        self, start: Key, actions: Sequence[LatticeAction], goals: Sequence[LegGoal]
    ) -> LatticeGraph:
        """The plan's own moves and visits as a lattice problem's graph (every move in it has
        just been checked free)."""
        graph = LatticeGraph(start, self.grid.encode(start))
        for step in plan_steps(self.grid, actions) or []:
            if step.motion is None:
                graph.near.add((step.state, step.goal))
            else:
                graph.edges.add((step.state, step.after, step.label))
        for g in goals:
            graph.goals.append((g.index, g.x, g.y, leg_reach(g)))
        return graph


def leg_reach(goal: LegGoal) -> float:
    """How close the tracked point must come to a goal for the plan to visit it."""
    return max(0.03, 0.6 * goal.tolerance)

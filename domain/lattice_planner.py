"""Plans tours of goals on the state lattice with pyperplan's searches, leg by leg.

Before any search, a footprint-aware 2-D distance map per goal (Dijkstra over the cells the
body centroid can occupy, scipy's csgraph) decides most unreachable goals at once and names
the cause (enclosed by known or by sensed obstacles); it is also the search heuristic and the
goal-to-goal distance table that orders unordered goals (no state-space product over goals).
Each leg (current state to the head on the next goal) is one pyperplan search over a
``LatticeTask``. When the short search finds nothing closer, the map may have led it into a
passage the centroid fits but the body cannot turn in (a bent slot, a gap beside a bar): a
second short search follows a map of the ways with room to turn (``roomy_map``) before the
leg ends in a timeout or searches long.
"""

from __future__ import annotations

import math
import time
from collections.abc import Hashable, Sequence
from typing import Any

import numpy as np

from domain.goal_order import LegGoal, order_goals
from domain.lattice import Key, LatticeGrid, LatticeSettings, MotionTable, body_key
from domain.lattice_cache import MotionCache
from domain.lattice_doubt import apart, within_one_motion
from domain.lattice_entry import goal_entered
from domain.lattice_maps import PlannerMaps
from domain.lattice_plan import (
    LatticeAction,
    LatticePlan,
    plan_actions,
    search_failed,
    state_pose,
    unreachable,
)
from domain.lattice_reach import Reachability
from domain.lattice_repair import PlanRepairer, leg_reach
from domain.lattice_states import StatePool
from domain.lattice_task import Clearance, LatticeTask
from domain.leg_search import search_leg
from domain.pyperplan_adapter import (
    HEURISTICS,
    SEARCHES,
    CancelFlag,
    PlanResult,
    SearchStopped,
    stop_if_due,
)
from domain.reach_memory import ReachMemory
from sim.robot import Array
from sim.world import Bounds

PARTIAL_AFTER = 3000  # expansions after which a partial plan is taken, if it gets closer
# (an expansion budget, not seconds: the same mission and seed plan the same on any machine)
SEARCH_AGAIN = 40_000  # expansions of the search that follows when nothing got closer (the
# time limit stays a safety net; a budget, so a faster machine does not plan differently)
MOTION_CACHES = 12  # motion caches kept (one per shape and clearance family); the least
# recently used goes first (each holds up to ``lattice_cache.COMPILED_LIMIT`` states)


class LatticePlanner:
    """Plans on the lattice of one body shape against a world model's clearance."""

    def __init__(
        self,
        bounds: Bounds,
        settings: LatticeSettings = LatticeSettings(),  # noqa: B008 (frozen, shared safely)
        search: str = "gbf",
        heuristic: str = "lattice",
        time_limit: float = 5.0,
    ) -> None:
        if search not in SEARCHES:
            raise ValueError(f"search: one of {', '.join(SEARCHES)}")
        if heuristic != "lattice" and heuristic not in HEURISTICS:
            raise ValueError(f"heuristic: 'lattice' or one of {', '.join(HEURISTICS)}")
        self.grid = LatticeGrid(bounds, settings)
        self.settings = settings
        self.search, self.heuristic, self.time_limit = search, heuristic, time_limit
        self.maps = PlannerMaps(self.grid)  # distance maps and clearances per world version
        # Whether a roomy map can redirect the search: a greedy one led by the distance map (its
        # extra cost on cells without room is a preference there; it would inflate an A*'s).
        self._guided = heuristic == "lattice" and search == "gbf"
        self.reach_memory = ReachMemory(self.grid, settings.margin)
        self._motions: dict[tuple[Any, ...], MotionCache] = {}
        self.states = StatePool()  # search states shared by every search on this grid
        self.repairer = PlanRepairer(
            self.grid,
            settings.margin,
            settings.start_margin,
            SEARCHES[search],
            self.actions_of,
            self.motion_cache,
        )

    # -- lattice states ---------------------------------------------------------------------
    def key_of(self, table: MotionTable, pose: Sequence[float]) -> Key:
        """The lattice state of a real pose: its centroid's cell and nearest orientation."""
        p = np.asarray(pose, dtype=float)
        c = table.centroid(p)
        i, j = self.grid.cell(float(c[0]), float(c[1]))
        k = round(float(p[2]) / self.settings.step) % self.settings.orientations
        return i, j, k

    def pose_of(self, table: MotionTable, key: Key) -> Array:
        """The tracked-point pose of ``table``'s body at lattice state ``key``."""
        return state_pose(self.grid, table, key)

    def _roomy_search(
        self,
        table: MotionTable,
        clearance: Clearance,
        version: Any,
        goal: LegGoal,
        here: Key,
        first: bool,
        origin: tuple[float, float],
        relaxed: Array,
        deadline: float,
        cancel: CancelFlag | None,
        cache: MotionCache,
    ) -> tuple[LatticeTask, PlanResult] | None:
        """A whole leg found by a short search along the ways with room, when the usual map's
        way from ``here`` is shorter (it passes where the body has no room to turn, so it may
        be what the short search got lost in); the cancelled search when a cancel stopped it
        (the plan ends cancelled); ``None`` otherwise. ``relaxed``: the usual map, made with
        the cells near the plan's start ``origin`` passable."""
        i, j, _ = here
        xy = self.grid.centre(i, j)
        start = (float(xy[0]), float(xy[1]))
        roomy = self.maps.roomy(
            table, clearance, version, goal, start, origin, relaxed, self.settings.margin
        )
        if not (
            math.isfinite(roomy[i, j])
            and roomy[i, j] > relaxed[i, j] + self.grid.settings.resolution
        ):
            return None  # no roomy way, or the same way: the same search again
        task = self._leg(table, clearance, here, goal, first, deadline, cancel, cache)
        task.budget = PARTIAL_AFTER
        result = self._search(task, roomy)
        if result.status == "cancelled":
            return task, result
        if not result.solved or result.reason == "partial":
            return None
        return task, result

    def cut_off(
        self,
        table: MotionTable,
        clearance: Clearance,
        version: Any,
        pose: Sequence[float],
        goals: Sequence[LegGoal],
        cancel: CancelFlag | None = None,
    ) -> bool:
        """Whether some goal's distance map has no way to the start's cell: what ``plan``
        answers ``unreachable`` to before any search (the maps are kept for it). ``True``
        once ``cancel`` is set (a cancelled mission has no use for more maps)."""
        si, sj, _ = self.key_of(table, pose)
        here = tuple(float(v) for v in self.grid.centre(si, sj))
        return any(
            (cancel is not None and cancel.is_set())
            or not math.isfinite(
                self.maps.distances(table, clearance, version, g, (here[0], here[1]))[si, sj]
            )
            for g in goals
        )

    def reachability(
        self, table: MotionTable, clearance: Clearance, version: Any, family: Hashable = None
    ) -> Reachability:
        """The free configuration space's components for this world version and shape; the
        answers for an earlier version of the same ``family`` of clearance (see ``plan``) are
        updated where the clearance changed rather than made afresh."""
        return self.reach_memory.get(
            table, lambda: self.maps.centre_clearance(clearance, version), version, family
        )

    # -- planning -----------------------------------------------------------------------------
    def plan(
        self,
        table: MotionTable,
        clearance: Clearance,
        version: Any,
        pose: Sequence[float],
        goals: Sequence[LegGoal],
        ordered: bool,
        cancel: CancelFlag | None = None,
        static: tuple[Clearance, Any] | None = None,
        previous: Sequence[LatticeAction] = (),
        reachable: bool = False,
        family: Hashable = None,
        doubt: bool = False,
        quick: bool = False,
    ) -> LatticePlan:
        """A plan from ``pose`` through ``goals`` (in the given order, or the best found).

        ``static`` is the clearance of the known obstacles alone: when a goal is cut off, it
        tells whether the known map already encloses it or sensing did. ``previous`` is what
        remains of the last plan: if a local repair makes it free again (domain/lattice_repair.py),
        that is the plan; otherwise one is searched from scratch. ``reachable``: the first
        leg's goal is known to be reachable from ``pose`` (the reachability test said so for a
        clearance this one keeps at most), so that test is not asked again after a long search.
        ``family`` names the kind of clearance this is (e.g. a tier of the navigation
        strategy's): which motions are free is kept between replans per shape and family, so
        that plans alternating between kinds of clearance do not make each other's verdicts
        stale (see ``motion_cache``). ``doubt``: the first leg's goal was unreachable at the
        last replan against this family, so the reachability test is asked before searching
        rather than after: when it says no, no search can reach the goal either, and the plan
        is the same ``unreachable`` the search would have ended in (a goal within one motion's
        reach is searched first all the same). ``quick``: the short search only; a leg whose
        search finds nothing closer ends in ``timeout`` without searching again, longer (the
        navigation strategy asks a looser tier's short search before this one's long one).
        """
        started = time.monotonic()
        deadline = started + self.time_limit
        if previous and self.heuristic == "lattice" and self.search != "bfs":
            start = self.key_of(table, pose)
            fixed = self.repairer.repair(
                table, clearance, start, goals, previous, ordered, deadline, cancel, family
            )
            if fixed is not None:
                done = LatticePlan(
                    "solved", "repaired", fixed.actions, fixed.order, fixed.expansions
                )
                done.graph, done.repaired = fixed.graph, True
                done.search_ms = (time.monotonic() - started) * 1e3
                return done
        cache = self.motion_cache(table, family)
        cache.refresh(self.maps.centre_clearance(clearance, version), version)
        start = self.key_of(table, pose)
        si, sj, _ = start
        here_xy = tuple(float(v) for v in self.grid.centre(si, sj))
        maps: dict[int, Array] = {}
        try:  # preparing is planning too: inside the time limit, and cancellable
            for g in goals:
                stop_if_due(cancel, deadline)
                maps[g.index] = self.maps.distances(
                    table, clearance, version, g, (here_xy[0], here_xy[1])
                )
        except SearchStopped as stop:
            why = (
                "planning cancelled"
                if stop.status == "cancelled"
                else f"planning timeout: the distance maps of {len(goals)} goals took longer "
                f"than {self.time_limit:g} s to prepare"
            )
            done = LatticePlan(stop.status, why)
            done.search_ms = (time.monotonic() - started) * 1e3
            return done
        for g in goals:
            if not math.isfinite(maps[g.index][si, sj]):
                return LatticePlan("unreachable", self.maps.enclosed(table, g, (si, sj), static))
        order = list(goals) if ordered else order_goals(self.grid, goals, maps, (si, sj))
        first = order[0]
        task = self._leg(table, clearance, start, first, True, deadline, cancel, cache)
        if (
            doubt
            and not reachable
            and not within_one_motion(self.grid, table, start, first)
            and self._apart(table, clearance, version, family, task, start, first, 0)
        ):
            if cancel is not None and cancel.is_set():
                return LatticePlan("cancelled", "planning cancelled")
            return unreachable(table.shape, first, started)
        plan = LatticePlan("solved", order=[g.index for g in order])
        here = start
        for leg, goal in enumerate(order):
            if leg > 0:
                task = self._leg(table, clearance, here, goal, False, deadline, cancel, cache)
            task.budget = PARTIAL_AFTER
            if leg == 0:
                plan.task = task
            result = self._search(task, maps[goal.index])
            long_search = result.status == "timeout" or result.reason == "partial"
            # After a long search, first make sure the body can get there at all: the resting
            # body's free configurations connect the start with the goal (domain/lattice_reach.py)
            # and, before searching again when nothing got closer, some free motion ends on the
            # goal (domain/lattice_entry.py). A partial plan is left to run instead: on the way,
            # sensing may clear what this tier keeps clear of only on a guess (a suspected
            # surface), which a plan that gives up on the tier would never learn.
            known = leg == 0 and reachable  # (the resting-body test passed in a stricter tier)
            if long_search:
                enters = result.status != "timeout" or goal_entered(task)
                if not enters or (
                    not known
                    and self._apart(table, clearance, version, family, task, here, goal, leg)
                ):
                    plan.status, plan.actions = "unreachable", []
                    plan.reason = unreachable(table.shape, goal, started).reason
                    break
                plan.reachable = plan.reachable or (leg == 0 and not known)
            if result.status == "timeout" and self._guided and time.monotonic() < deadline:
                roomy = self._roomy_search(
                    table, clearance, version, goal, here, leg == 0, (here_xy[0], here_xy[1]),
                    maps[goal.index], deadline, cancel, cache,
                )  # fmt: skip
                if roomy is not None:
                    plan.expansions += task.expansions
                    task, result = roomy
                    if leg == 0:
                        plan.task = task
            if result.status == "timeout" and not quick and time.monotonic() < deadline:
                # Nothing closer to go to yet: search again, longer.
                task = self._leg(table, clearance, here, goal, leg == 0, deadline, cancel, cache)
                task.budget = SEARCH_AGAIN
                if leg == 0:
                    plan.task = task
                result = self._search(task, maps[goal.index])
            plan.expansions += task.expansions
            plan.legs.append(task)
            if not result.solved:
                plan.status = result.status
                budget = PARTIAL_AFTER + (0 if quick else SEARCH_AGAIN)
                plan.reason = search_failed(result, table.shape, goal, budget, self.time_limit)
                plan.actions = []
                break
            actions, here = self.actions_of(task, table, result.plan)
            plan.actions += actions
            if result.reason == "partial":  # the rest is planned again from there
                plan.partial = True
                break
        plan.search_ms = (time.monotonic() - started) * 1e3
        return plan

    def _leg(
        self,
        table: MotionTable,
        clearance: Clearance,
        start: Key,
        goal: LegGoal,
        first: bool,
        deadline: float,
        cancel: CancelFlag | None,
        cache: MotionCache | None,
    ) -> LatticeTask:
        """The task of one leg: from ``start`` to the tracked point on ``goal``, reading and
        keeping free motions in ``cache``."""
        task = LatticeTask(
            self.grid,
            table,
            clearance,
            start,
            (goal.x, goal.y),
            leg_reach(goal),
            self.settings.margin,
            self.settings.start_margin if first else self.settings.margin,
            goal.index,
            self.states,
        )
        task.deadline, task.cancel = deadline, cancel
        task.cache = cache
        task.at_centres = self.maps.at_centres
        return task

    def motion_cache(self, table: MotionTable, family: Hashable = None) -> MotionCache:
        """The free motions of this shape's lattice kept between replans against clearances
        of one ``family``. A cache refreshed against another kind of clearance (another tier:
        suspected surfaces avoided, or passed closely) forgets every state near where the two
        differ, and that is most of a cluttered way; one per family keeps each kind's verdicts
        for its next replan, where only what was sensed since is forgotten."""
        key = (*body_key(table), self.settings.margin, family)
        cache = self._motions.pop(key, None)
        if cache is None:
            if len(self._motions) >= MOTION_CACHES:  # the least recently used goes
                del self._motions[next(iter(self._motions))]
            cache = MotionCache(self.grid, table, self.settings.margin, self.states)
        self._motions[key] = cache  # (the newest last)
        return cache

    def _search(self, task: LatticeTask, distances: Array) -> PlanResult:
        """One leg's search (``domain/leg_search.py``)."""
        return search_leg(task, distances, self.search, self.heuristic)

    def actions_of(
        self, task: LatticeTask, table: MotionTable, names: list[str]
    ) -> tuple[list[LatticeAction], Key]:
        """A searched plan's operator names as plan actions, and the state it ends in."""
        return plan_actions(self.grid, task, table, names)

    def _apart(
        self,
        table: MotionTable,
        clearance: Clearance,
        version: Any,
        family: Hashable,
        task: LatticeTask,
        here: Key,
        goal: LegGoal,
        leg: int,
    ) -> bool:
        """Whether the reachability test keeps ``goal`` apart from ``here`` (``task``: the leg
        from there). The first leg's first motion keeps only the start's allowance, which
        the test does not grant: it must also keep the goal apart from where each free one
        leads (``lattice_doubt.apart``); later legs start where a motion keeping the margin
        ended."""
        answers = self.reachability(table, clearance, version, family)
        if leg > 0:
            return not answers.reaches(here, (goal.x, goal.y), task.reach)
        return apart(answers, here, goal, lambda: [k for k, _ in task.valid_motions(here)])

"""Runs one mission: builds its robot port, world model, strategy and tree; ticks in model time.

Our own loop ticks the tree (no ``tick_tock``, no wall-clock timeouts): one tick decides the
command for one control tick, then the robot runs it through the Robot port. Deterministic for
a mission and seed. ``step()`` advances one tick so a service can pace and stream it.
"""

from __future__ import annotations

import itertools
import math
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import py_trees
from py_trees.common import Access, Status

from app.executor.context import GoalState, MissionContext, MissionResult
from app.executor.learning import (
    LearningSettings,
    ShapeLearner,
    lattice_shape,
    learn_here,
    learned_event,
)
from app.executor.plan_versions import SEARCHES_KEPT
from app.executor.robot import Robot, head_sensors, sim_robot
from app.executor.tree import build_tree, snapshot
from app.missions.spec import MissionSpec
from domain.knowledge import Goal
from domain.navigation import (
    HeadView,
    NavigationSettings,
    NavigationStrategy,
    Planner,
    warm_tables,
)
from domain.pyperplan_adapter import CancelFlag
from domain.reactive_strategy import ReactiveStrategy
from domain.strategy import PlanningStrategy
from domain.triggers import GoalsChanged, ObstacleAdded, Resumed
from domain.world import WorldModel
from primitives.grounding import TICK
from primitives.library import Library
from primitives.shape_learning import LearnedShape, LearningCancelled, LearningStopped
from primitives.shapes import learned_joints, learned_name
from sim.controls import FixedShape
from sim.obstacles import Obstacle

MAX_RETICKS = 4  # ticks within one control tick while the tree only plans
CANCELLED = "cancelled by request"
TRAJECTORY_POINTS = 2000
_ids = itertools.count()

TickHook = Callable[[MissionContext, dict[str, Any]], None]
LearningHook = Callable[[MissionContext], None]  # learning started or progressed


class MissionError(ValueError):
    """A mission that cannot start (e.g. its start pose overlaps an obstacle)."""


class UpdateRefused(ValueError):
    """A live update that cannot apply now (e.g. removing a goal already reached)."""


def navigation_settings(spec: MissionSpec) -> NavigationSettings:
    """The mission's navigation settings: the defaults with the mission's margin."""
    return NavigationSettings(margin=spec.planner.margin)


def make_strategy(spec: MissionSpec, library: Library) -> PlanningStrategy | None:
    """The planning strategy the mission asks for (none for a manual chain)."""
    if not spec.goals:
        return None
    p = spec.planner
    own = p.heuristic in ("cost", "roadmap", "lattice")
    if p.domain == "reactive":
        heuristic: str = "hff" if own else p.heuristic
        try:
            return ReactiveStrategy(
                library,
                "gbf" if p.search == "cost" else p.search,
                heuristic,
                p.time_limit,
                {str(op): name for op, name in p.operators.items()},
                p.threshold,
                p.clearance,
                p.timeout_return,
            )
        except (KeyError, ValueError) as exc:
            raise MissionError(f"planner.operators: {str(exc).strip(chr(34))}") from exc
    heuristic = "cost" if own else p.heuristic
    search = p.search
    settings = navigation_settings(spec)
    planner = Planner(spec.bounds.bounds(), settings, search, heuristic, p.time_limit)
    return NavigationStrategy(library, planner, HeadView.of(head_sensors(spec)))


class MissionRunner:
    def __init__(
        self,
        spec: MissionSpec,
        library: Library,
        mission_id: str | None = None,
        on_tick: TickHook | None = None,
        cancel: CancelFlag | None = None,
        robot: Robot | None = None,
        searches_kept: int = SEARCHES_KEPT,
        learning: LearningSettings | None = None,
        learner: ShapeLearner = learn_here,
        on_learning: LearningHook | None = None,
    ) -> None:
        if searches_kept < 1:
            raise ValueError(
                f"searches_kept: at least 1 plan version (the one being run), got {searches_kept}"
            )
        self.spec = spec
        self.on_tick = on_tick
        self.cancel = cancel or threading.Event()
        self.namespace = f"/mission_{mission_id or next(_ids)}"
        self.started = time.perf_counter()
        self.status: str = "executing"
        self.reason = ""
        self.paused_at: float | None = None  # model time when paused; None while running
        unknown = spec.unknown_primitive(library)
        if unknown is not None:  # the same answer the API gives, not a KeyError mid-run
            raise MissionError(
                f"chain.{unknown[0]}: primitive {unknown[1]!r} is not in the library"
            )
        try:
            self.robot = robot or sim_robot(spec)
        except ValueError as exc:
            raise MissionError(str(exc)) from exc
        self.learner, self.on_learning = learner, on_learning
        self.learned: list[LearnedShape] = []  # shapes this mission learned, oldest first
        self.ctx = self._context(spec, library, self.robot, learning or LearningSettings())
        self.ctx.cancel = self.cancel  # the planner stops its search when it is set
        self.ctx.learn_shape = self.learn_shape  # a deformation into a shape without a lattice
        self.ctx.searches_kept = searches_kept  # newest plan versions keeping their searches whole
        self._writer = py_trees.blackboard.Client(name="runner", namespace=self.namespace)
        self._writer.register_key("context", access=Access.WRITE)
        self._writer.context = self.ctx
        self.tree = build_tree(spec, self.namespace, self.ctx.settings.recovery)
        self.tree.setup_with_descendants()

    @staticmethod
    def _context(
        spec: MissionSpec, library: Library, robot: Robot, learning: LearningSettings
    ) -> MissionContext:
        joints = spec.start_joints()
        shape: str | None = spec.shape_name()
        learn = False
        if shape == "custom" or learned_joints(str(shape)) is not None:
            if spec.goals and spec.planner.domain == "navigation":
                shape, learn = lattice_shape(library, joints, learning)
            else:  # the paper's moves and chains blend paper primitives of library shapes
                coverage = library.covers(joints)
                shape = coverage.shape
                if shape is None:
                    raise MissionError(f"shape: joints {list(joints)}: {coverage.describe()}")
        assert shape is not None
        known = [o for o in spec.world_obstacles() if o.known]
        settings = navigation_settings(spec)
        maps = [raster for raster, is_known in spec.world_maps() if is_known]
        world = WorldModel(spec.bounds.bounds(), known, settings.costmap, maps=maps)
        observation = robot.observe()
        ctx = MissionContext(
            spec=spec,
            library=library,
            robot=robot,
            world=world,
            strategy=make_strategy(spec, library),
            observation=observation,
            goals=[GoalState(g.x, g.y, g.tolerance) for g in spec.goals],
            shape=shape,
            joints=joints,
            settings=settings,
            view=HeadView.of(head_sensors(spec)),
            interval=TICK,
            learning_settings=learning,
        )
        if learn:
            ctx.learn = joints  # learned before the first plan
        for entry in observation.log:
            ctx.event(
                str(entry.get("kind")), **{k: v for k, v in entry.items() if k not in ("t", "kind")}
            )
        return ctx

    # -- running ------------------------------------------------------------------------------
    @property
    def done(self) -> bool:
        return self.status != "executing"

    def step(self) -> bool:
        """Tick the tree and run its command for one control tick; True when done."""
        if self.done:
            return True
        ctx = self.ctx
        if self.cancel.is_set():
            return self._finish("cancelled", CANCELLED)
        if self.paused:  # model time stands still until resumed
            return False
        if ctx.learn is not None:  # the start shape, before its first plan
            joints, ctx.learn = ctx.learn, None
            why = self.learn_shape(joints)
            if why is not None:
                return self._finish("cancelled" if why == CANCELLED else "failed", why)
        for _ in range(MAX_RETICKS):
            ctx.command = None
            self.tree.tick_once()
            if self.tree.status != Status.RUNNING or ctx.command is not None:
                break
        if self.cancel.is_set():  # a cancel during planning ends the mission as cancelled
            return self._finish("cancelled", "cancelled by request")
        if self.tree.status == Status.SUCCESS:
            return self._finish(
                "succeeded", "all goals reached" if ctx.goals else "chain completed"
            )
        if self.tree.status == Status.FAILURE:
            reason = ctx.failure or ctx.failure_reason or "the behaviour tree failed"
            return self._finish("failed", reason)
        if ctx.command is None:  # hold still
            ctx.current_action, ctx.grounding = "hold", {}
        command = ctx.command or FixedShape.of(np.zeros(4), ctx.joints)
        ctx.record_executed(TICK)
        ctx.observation = self.robot.act(command, TICK)
        for entry in ctx.observation.log:
            ctx.event(
                str(entry.get("kind")), **{k: v for k, v in entry.items() if k not in ("t", "kind")}
            )
        if self.on_tick is not None:
            self.on_tick(ctx, self.snapshot())
        if ctx.t >= self.spec.time_limit - 1e-9:
            return self._finish(
                "failed", f"time limit: {self.spec.time_limit:g} model seconds reached"
            )
        return False

    def learn_shape(self, joints: tuple[float, float, float]) -> str | None:
        """Learn the lattice set of the shape ``joints`` while the robot stands still (inside
        the tick that found it: no control tick runs, so no model time passes), then go on with
        the library it joined, its lattice's tables made; None, or why it could not (cancelled,
        past the budget, no motion learned: the mission ends with that reason)."""
        ctx = self.ctx
        shape = learned_name(joints)
        shown = ctx.current_action, ctx.grounding
        ctx.learning = {"shape": shape, "done": 0, "total": 0}
        ctx.current_action, ctx.grounding = f"learning {shape}", {}

        def progress(done: int, total: int) -> None:
            ctx.learning = {"shape": shape, "done": done, "total": total}
            if self.on_learning is not None:
                self.on_learning(ctx)

        try:
            learned = self.learner(joints, ctx.learning_settings, self.cancel.is_set, progress)
        except LearningCancelled:
            return CANCELLED
        except LearningStopped as exc:
            return f"learning: {exc}"
        finally:
            ctx.learning = None
            ctx.current_action, ctx.grounding = shown
        if not learned.entries:
            return f"learning: shape {learned.shape}: no lattice motion reached the bar"
        library = ctx.library.with_entries(learned.entries)
        self.use_library(library)
        begun = time.perf_counter()  # the new lattice's tables now, not in the first replan
        warm_tables(library, ctx.settings, ctx.view, shapes=(learned.shape,))
        self.learned.append(learned)
        ctx.event("learned", **learned_event(learned, library, time.perf_counter() - begun))
        return None

    def use_library(self, library: Library) -> None:
        """Run on ``library`` from now on (a new version: the old one's entries and more)."""
        self.ctx.library = library
        if isinstance(self.ctx.strategy, NavigationStrategy):
            self.ctx.strategy.library = library

    # -- live updates (each a typed trigger: the tree replans on its next tick) -------------------
    @property
    def paused(self) -> bool:
        return self.paused_at is not None

    def _trigger(self, trigger: GoalsChanged | ObstacleAdded | Resumed) -> None:
        if self.ctx.strategy is None:
            raise UpdateRefused("this mission has no planner (a chain of primitives)")
        if self.ctx.trigger is None:  # a pending trigger replans too, with the update in view
            self.ctx.trigger = trigger

    def add_goal(self, x: float, y: float, tolerance: float) -> int:
        """Append a goal (its index follows the goals as posted) and replan."""
        self._trigger(GoalsChanged(added=(Goal(x, y, tolerance),)))
        self.ctx.goals.append(GoalState(x, y, tolerance))
        index = len(self.ctx.goals) - 1
        self.ctx.event("update", update="add_goal", detail={"goal": index, "x": x, "y": y})
        return index

    def remove_goal(self, index: int) -> None:
        """Stop pursuing goal ``index`` (as posted) and replan; a reached goal stays."""
        goals = self.ctx.goals
        if not 0 <= index < len(goals):
            raise UpdateRefused(f"goal {index}: no such goal (0..{len(goals) - 1})")
        goal = goals[index]
        if goal.reached:
            raise UpdateRefused(f"goal {index}: already reached at {goal.reached_at} model s")
        if goal.removed:
            raise UpdateRefused(f"goal {index}: already removed")
        self._trigger(GoalsChanged(removed=(Goal(goal.x, goal.y, goal.tolerance),)))
        goal.removed = True
        self.ctx.event("update", update="remove_goal", detail={"goal": index})

    def add_obstacle(self, obstacle: Obstacle) -> None:
        """A known obstacle into the world model (not the simulated world) and replan."""
        self._trigger(ObstacleAdded(obstacle))
        self.ctx.world.add_known(obstacle)
        self.ctx.event("update", update="add_obstacle", detail={"obstacle": obstacle.to_dict()})

    def pause(self) -> None:
        """Hold still: no ticks, model time stops, until resumed or cancelled."""
        if self.paused:
            raise UpdateRefused("already paused")
        self.paused_at = self.ctx.t
        self.ctx.event("update", update="pause", detail={})

    def resume(self) -> None:
        """Go on from where it paused, with a fresh plan."""
        if self.paused_at is None:
            raise UpdateRefused("not paused")
        paused_at, self.paused_at = self.paused_at, None
        self.ctx.event("update", update="resume", detail={"paused_at": paused_at})
        if self.ctx.strategy is not None and self.ctx.trigger is None:
            self.ctx.trigger = Resumed(paused_at)

    def run(self) -> MissionResult:
        while not self.step():
            pass
        return self.result()

    def abort(self, status: str, reason: str) -> None:
        """End the mission from outside the tree (e.g. a wall-clock limit)."""
        if not self.done:
            self._finish(status, reason)

    def _finish(self, status: str, reason: str) -> bool:
        self.status, self.reason = status, reason
        self.ctx.close_executed()
        py_trees.blackboard.Blackboard.unset(f"{self.namespace}/context")
        return True

    # -- views ----------------------------------------------------------------------------------
    def snapshot(self) -> dict[str, Any]:
        ctx = self.ctx
        x, y, psi = ctx.pose
        return {
            "t": round(ctx.t, 3),
            "pose": {"x": x, "y": y, "psi": psi, "joints": list(ctx.sensed_joints())},
            "action": ctx.current_action,
            "grounding": ctx.grounding,
            "sensors": ctx.observation.sensors_dict(),
            "tree": snapshot(self.tree),
            "shape": ctx.shape,
            "learning": ctx.learning,
        }

    def plan_actions(self) -> list[dict[str, Any]]:
        return self.ctx.strategy.actions() if self.ctx.strategy is not None else []

    def trajectory(self, limit: int = TRAJECTORY_POINTS) -> list[list[float]]:
        rows = self.robot.trajectory()
        stride = max(1, math.ceil(len(rows) / limit))
        picked = rows[::stride]
        if picked[-1] is not rows[-1]:
            picked.append(rows[-1])
        return [[round(v, 5) for v in row] for row in picked]

    def result(self) -> MissionResult:
        ctx = self.ctx
        return MissionResult(
            name=self.spec.name,
            status=self.status,
            reason=self.reason,
            goals=ctx.goals,
            collisions=ctx.contacts,
            replans=[r for r in ctx.replans if r.trigger != "initial"],
            model_time=round(ctx.t, 3),
            wall_time=time.perf_counter() - self.started,
            trajectory=self.trajectory(),
            events=ctx.events,
            pddl=ctx.pddl,
            executed=ctx.executed,
        )


def run_mission(spec: MissionSpec, library: Library) -> MissionResult:
    return MissionRunner(spec, library).run()


__all__ = ["MissionError", "MissionRunner", "UpdateRefused", "run_mission"]

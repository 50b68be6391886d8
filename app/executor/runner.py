"""Runs one mission: builds its world, knowledge and tree, and ticks it in model time.

Our own loop ticks the tree (no ``tick_tock``, no wall-clock timeouts): one tick decides the
command for one control interval, then the simulator steps through it. Deterministic for a
mission and seed. ``step()`` advances one interval so a service can pace and stream it.
"""

from __future__ import annotations

import itertools
import math
import threading
import time
from collections.abc import Callable
from typing import Any, Protocol

import numpy as np
import py_trees
from py_trees.common import Access, Status

from app.executor.context import GoalState, MissionContext, MissionResult
from app.executor.tree import build_tree, snapshot
from app.missions.spec import DeformEvent, MissionSpec
from domain.knowledge import Goal, WorldKnowledge
from domain.navigation import NavigationPlanner
from domain.replanner import Replanner
from primitives.library import Library
from primitives.shapes import classify_shape
from primitives.steering import Steering
from sim.controls import FixedShape
from sim.events import Deformation, SensorDropout
from sim.sensors import RangeSensor, SensorSuite, range_ring
from sim.simulator import Simulator
from sim.world import World

CONTROL_INTERVAL = 1.0  # model seconds per tick
SIM_DT = 0.5  # model seconds per simulator step
MAX_RETICKS = 4  # ticks within one interval while the tree only plans
TRAJECTORY_POINTS = 2000
_ids = itertools.count()

TickHook = Callable[[MissionContext, dict[str, Any]], None]


class CancelFlag(Protocol):
    """A threading or multiprocessing event: only ``is_set`` is needed."""

    def is_set(self) -> bool: ...


class MissionError(ValueError):
    """A mission that cannot start (e.g. its start pose overlaps an obstacle)."""


class MissionRunner:
    def __init__(
        self,
        spec: MissionSpec,
        library: Library,
        steering: Steering | None = None,
        mission_id: str | None = None,
        on_tick: TickHook | None = None,
        cancel: CancelFlag | None = None,
    ) -> None:
        self.spec = spec
        self.on_tick = on_tick
        self.cancel = cancel or threading.Event()
        self.namespace = f"/mission_{mission_id or next(_ids)}"
        self.started = time.perf_counter()
        self.status: str = "executing"
        self.reason = ""
        self.ctx = self._context(spec, library, steering or Steering(library))
        self._writer = py_trees.blackboard.Client(name="runner", namespace=self.namespace)
        self._writer.register_key("context", access=Access.WRITE)
        self._writer.context = self.ctx
        self.tree = build_tree(spec, self.namespace)
        self.tree.setup_with_descendants()

    @staticmethod
    def _context(spec: MissionSpec, library: Library, steering: Steering) -> MissionContext:
        obstacles = tuple(spec.world_obstacles())
        ring = (
            range_ring(spec.sensors.ring, spec.sensors.range, spec.sensors.noise)
            if spec.sensors.ring
            else ()
        )
        ir = RangeSensor("ir", 0.0, spec.sensors.ir_range, math.radians(10), 3, spec.sensors.noise)
        sensors = SensorSuite(range_sensors=(ir, *ring))
        # Dropouts are scheduled like deformations; the simulator reads dropped sensors as NaN.
        events = tuple(
            Deformation(e.t, e.joints)
            if isinstance(e, DeformEvent)
            else SensorDropout(e.t, e.duration, tuple(e.sensors))
            for e in spec.events
        )
        world = World(spec.bounds.bounds(), obstacles)
        try:
            sim = Simulator(world, sensors=sensors, events=events, dt=SIM_DT)
            sim.reset(
                (spec.start.x, spec.start.y, spec.start.psi), spec.start_joints(), seed=spec.seed
            )
        except ValueError as exc:
            raise MissionError(str(exc)) from exc
        joints = spec.start_joints()
        shape = classify_shape(joints) if spec.shape_name() == "custom" else spec.shape_name()
        if shape is None:
            raise MissionError(f"shape: joints {list(joints)} match no library shape")
        known = tuple(o for o in obstacles if o.known)
        goals = [GoalState(g.x, g.y, g.tolerance) for g in spec.goals]
        knowledge = WorldKnowledge(
            (spec.start.x, spec.start.y, spec.start.psi),
            shape,
            tuple(Goal(g.x, g.y, g.tolerance) for g in spec.goals),
            spec.order,
            known,
            (),
            spec.bounds.bounds(),
            joints,
        )
        ctx = MissionContext(
            spec, library, steering, sim, knowledge, goals, shape=shape, interval=CONTROL_INTERVAL
        )
        ctx.readings = sim.read()
        if spec.planner.domain == "navigation" and spec.goals:
            p = spec.planner
            inflation = sim.geometry.unit_radius + p.margin
            planner = NavigationPlanner(
                knowledge, library, p.spacing, inflation, p.search, p.heuristic, p.time_limit
            )
            ctx.replanner = Replanner(planner)
        for event in sim.initial_events:
            ctx.event(event.kind, **event.detail)
        return ctx

    # -- running ------------------------------------------------------------------------------
    @property
    def done(self) -> bool:
        return self.status != "executing"

    def step(self) -> bool:
        """Tick the tree and advance the simulator by one control interval; True when done."""
        if self.done:
            return True
        ctx = self.ctx
        if self.cancel.is_set():
            return self._finish("cancelled", "cancelled by request")
        for _ in range(MAX_RETICKS):
            ctx.command = None
            self.tree.tick_once()
            if self.tree.status != Status.RUNNING or ctx.command is not None:
                break
        if self.tree.status == Status.SUCCESS:
            return self._finish(
                "succeeded", "all goals reached" if ctx.goals else "chain completed"
            )
        if self.tree.status == Status.FAILURE:
            return self._finish("failed", ctx.failure or "the behaviour tree failed")
        command = ctx.command or FixedShape.of(np.zeros(4), ctx.sim.joints)  # hold still
        for _ in range(round(CONTROL_INTERVAL / SIM_DT)):
            result = ctx.sim.step(command)
            for event in result.events:
                ctx.event(event.kind, **event.detail)
        ctx.readings = result.readings
        if self.on_tick is not None:
            self.on_tick(ctx, self.snapshot())
        if ctx.t >= self.spec.time_limit:
            return self._finish(
                "failed", f"time limit of {self.spec.time_limit:g} model seconds reached"
            )
        return False

    def run(self) -> MissionResult:
        while not self.step():
            pass
        return self.result()

    def _finish(self, status: str, reason: str) -> bool:
        self.status, self.reason = status, reason
        py_trees.blackboard.Blackboard.unset(f"{self.namespace}/context")
        return True

    # -- views ----------------------------------------------------------------------------------
    def snapshot(self) -> dict[str, Any]:
        ctx = self.ctx
        x, y, psi = ctx.pose
        return {
            "t": round(ctx.t, 3),
            "pose": {"x": x, "y": y, "psi": psi, "joints": [float(v) for v in ctx.sim.joints]},
            "action": ctx.current_action,
            "grounding": ctx.grounding,
            "sensors": ctx.readings.to_dict() if ctx.readings else {},
            "tree": snapshot(self.tree),
            "shape": ctx.shape,
        }

    def trajectory(self, limit: int = TRAJECTORY_POINTS) -> list[list[float]]:
        rows = self.ctx.sim.trajectory
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
            collisions=ctx.sim.collisions,
            replans=[r for r in ctx.replans if r.trigger != "initial"],
            model_time=round(ctx.t, 3),
            wall_time=time.perf_counter() - self.started,
            trajectory=self.trajectory(),
            events=ctx.events,
            pddl=ctx.pddl,
        )


def run_mission(
    spec: MissionSpec, library: Library, steering: Steering | None = None
) -> MissionResult:
    return MissionRunner(spec, library, steering).run()


__all__ = ["MissionError", "MissionRunner", "run_mission"]

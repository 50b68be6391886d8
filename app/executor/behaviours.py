"""py_trees behaviours of the mission tree: conditions, guards, replanning and execution.

Behaviours decide; they never move the simulator. Each tick the tree leaves a command (one
control interval of screw speeds and joints) on the mission context, and the runner steps the
simulator in model time. Guards check the next action's preconditions from the sensors every
tick; a guard that fires leaves a typed trigger and fails, which hands control to ``Replan``.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import py_trees
from py_trees.common import Access, Status

from app.executor.context import MissionContext
from app.executor.sensing import blocked_towards, new_obstacles
from domain.knowledge import Goal
from domain.reactive import ReactiveState, plan_reactive, reactive_domain, reactive_problem
from domain.triggers import Initial, NoProgress, ObstacleSensed, ShapeChanged
from primitives.shapes import SHAPES, classify_shape
from sim.controls import FixedShape, PeriodicGait
from sim.obstacles import Circle, point_segment_distance

CRUISE_SPEED = 0.06  # m/s (screw speeds stay within ±0.8 rad/s)
WAYPOINT_REACH = 0.2  # metres: close enough to move on to the next waypoint
ARRIVE_FRACTION = 0.4  # stop within this fraction of a goal's tolerance
SHAPE_TOLERANCE = 0.1  # rad: sensed joints further than this from the commanded ones: deformed
NO_PROGRESS_TIME = 40.0  # model seconds without 5 cm of progress
PATH_CONFLICT = 1.2  # metres: a new obstacle this close to the path ahead breaks the plan
REACTIVE_CLEARANCE = 0.6  # metres to keep sidestepping after the goal direction is clear


class MissionBehaviour(py_trees.behaviour.Behaviour):
    """A behaviour reading the mission context from its blackboard namespace."""

    def __init__(self, name: str, namespace: str) -> None:
        super().__init__(name)
        self.bb = self.attach_blackboard_client(name=name, namespace=namespace)
        self.bb.register_key("context", access=Access.READ)

    @property
    def ctx(self) -> MissionContext:
        context: MissionContext = self.bb.context
        return context


def steer(ctx: MissionContext, tx: float, ty: float, speed: float) -> None:
    """Command one control interval towards (tx, ty), grounded from the library."""
    x, y, psi = ctx.pose
    direction = math.atan2(ty - y, tx - x) - psi  # start frame of the current pose
    shape = SHAPES[ctx.shape]
    joints = np.asarray(ctx.knowledge.joints or shape.joints)
    cmd = ctx.steering.command(ctx.shape, direction, speed, None if shape.periodic else joints)
    if cmd.phases is not None:
        ctx.command = PeriodicGait.of(cmd.theta, cmd.phases, t0=ctx.gait_t0)
    else:
        ctx.command = FixedShape.of(cmd.theta, cmd.joints if cmd.joints is not None else joints)
    ctx.grounding = cmd.grounding()


def arrive_speed(distance: float) -> float:
    return float(min(CRUISE_SPEED, max(distance, 0.005) / 2.0))


class GoalReached(MissionBehaviour):
    """SUCCESS once goal ``index`` (or every goal, for ``None``) is reached."""

    def __init__(self, name: str, namespace: str, index: int | None) -> None:
        super().__init__(name, namespace)
        self.index = index

    def update(self) -> Status:
        ctx = self.ctx
        x, y, _ = ctx.pose
        wanted = range(len(ctx.goals)) if self.index is None else [self.index]
        for i in wanted:
            g = ctx.goals[i]
            if not g.reached and g.distance(x, y) <= ARRIVE_FRACTION * g.tolerance:
                ctx.mark_reached(i)
        return Status.SUCCESS if all(ctx.goals[i].reached for i in wanted) else Status.FAILURE


class HavePlan(MissionBehaviour):
    def update(self) -> Status:
        ctx = self.ctx
        if ctx.trigger is not None or ctx.failure is not None:
            return Status.FAILURE
        if ctx.spec.planner.domain == "reactive":
            return Status.SUCCESS if ctx.reactive_steps else Status.FAILURE
        ok = (
            ctx.plan is not None
            and ctx.plan.result.solved
            and ctx.action_index < len(ctx.plan.actions)
        )
        return Status.SUCCESS if ok else Status.FAILURE


class ObstacleGuard(MissionBehaviour):
    """New range hits join the knowledge; a hit on the path ahead breaks the plan."""

    def update(self) -> Status:
        ctx = self.ctx
        fresh = new_obstacles(ctx)
        for ob in fresh:
            ctx.knowledge = ctx.knowledge.with_sensed(ob)
        if fresh:
            ctx.event("obstacle_sensed", points=[[round(o.x, 3), round(o.y, 3)] for o in fresh])
        if ctx.spec.planner.domain == "reactive":
            steps = ctx.reactive_steps
            goal = ctx.goals[ctx.remaining_goals()[0]] if ctx.remaining_goals() else None
            if steps and goal is not None and steps[0].operator == "PO1":
                x, y, _ = ctx.pose
                if blocked_towards(ctx, math.atan2(goal.y - y, goal.x - x)):
                    ctx.trigger = ObstacleSensed(fresh[0] if fresh else _marker(ctx))
                    return Status.FAILURE
            return Status.SUCCESS
        path = self._path_ahead(ctx)
        for ob in fresh:
            if (
                len(path) > 1
                and float(
                    np.min(point_segment_distance(np.array([ob.x, ob.y]), path[:-1], path[1:]))
                )
                < PATH_CONFLICT
            ):
                ctx.trigger = ObstacleSensed(ob)
                return Status.FAILURE
        return Status.SUCCESS

    @staticmethod
    def _path_ahead(ctx: MissionContext, steps: int = 8) -> np.ndarray:
        x, y, _ = ctx.pose
        points = [(x, y)]
        if ctx.plan is not None:
            for action in ctx.plan.actions[ctx.action_index : ctx.action_index + steps]:
                if action.target is not None:
                    points.append(action.target)
        return np.array(points)


def _marker(ctx: MissionContext) -> Circle:
    x, y, _ = ctx.pose
    return Circle(x, y, 0.01, name="reactive", known=False)


class ShapeGuard(MissionBehaviour):
    """The joint-angle sensors against the commanded shape: a deformation changes the shape."""

    def update(self) -> Status:
        ctx = self.ctx
        readings = ctx.readings
        if readings is None or not np.all(np.isfinite(readings.joints)):
            return Status.SUCCESS
        commanded = np.asarray(ctx.knowledge.joints or SHAPES[ctx.shape].joints)
        if SHAPES[ctx.shape].periodic and not ctx.sim.deformed:
            return Status.SUCCESS  # the gait moves the joints on purpose
        if float(np.max(np.abs(readings.joints - commanded))) <= SHAPE_TOLERANCE:
            return Status.SUCCESS
        sensed = tuple(float(v) for v in readings.joints)
        shape = classify_shape(sensed) or classify_shape(sensed, tolerance=0.4)
        if shape is None:
            ctx.failure = f"the body deformed into {np.round(sensed, 2).tolist()}, a shape the library has no primitives for"
            return Status.FAILURE
        ctx.shape = shape
        ctx.knowledge = replace(
            ctx.knowledge, shape=shape, joints=(sensed[0], sensed[1], sensed[2])
        )
        ctx.event("deform", joints=[round(v, 3) for v in sensed], shape=shape)
        ctx.trigger = ShapeChanged(shape, (sensed[0], sensed[1], sensed[2]))
        return Status.FAILURE


class ProgressGuard(MissionBehaviour):
    """No 5 cm of progress towards the current target for a while, or a collision: replan."""

    def update(self) -> Status:
        ctx = self.ctx
        target = current_target(ctx)
        if target is None:
            return Status.SUCCESS
        x, y, _ = ctx.pose
        d = math.hypot(target[0] - x, target[1] - y)
        if d < ctx.progress_best - 0.05:
            ctx.progress_best, ctx.progress_since = d, ctx.t
        if ctx.sim.collisions > ctx.collisions_seen:
            ctx.collisions_seen = ctx.sim.collisions
            ctx.trigger = NoProgress(ctx.current_action, "collision")
            return Status.FAILURE
        if ctx.t - ctx.progress_since > NO_PROGRESS_TIME:
            ctx.trigger = NoProgress(ctx.current_action, f"no progress for {NO_PROGRESS_TIME:g} s")
            return Status.FAILURE
        return Status.SUCCESS


def current_target(ctx: MissionContext) -> tuple[float, float] | None:
    if ctx.spec.planner.domain == "reactive":
        left = ctx.remaining_goals()
        return (ctx.goals[left[0]].x, ctx.goals[left[0]].y) if left else None
    if ctx.plan is None or ctx.action_index >= len(ctx.plan.actions):
        return None
    return ctx.plan.actions[ctx.action_index].target


class FollowPlan(MissionBehaviour):
    """Executes the plan: one control interval towards the current action's target per tick."""

    def update(self) -> Status:
        ctx = self.ctx
        if ctx.spec.planner.domain == "reactive":
            return self._reactive(ctx)
        assert ctx.plan is not None
        actions = ctx.plan.actions
        x, y, _ = ctx.pose
        while ctx.action_index < len(actions):
            action = actions[ctx.action_index]
            if action.name != "move":  # visit / visit-next: at the goal point
                mission_goal = ctx.goal_map[action.goal or 0]
                goal = ctx.goals[mission_goal]
                if goal.reached or goal.distance(x, y) <= ARRIVE_FRACTION * goal.tolerance:
                    ctx.mark_reached(mission_goal)
                    self._advance(ctx)
                    continue
                ctx.current_action = action.pddl
                steer(ctx, goal.x, goal.y, arrive_speed(goal.distance(x, y)))
                return Status.RUNNING
            assert action.target is not None
            tx, ty = action.target
            d = math.hypot(tx - x, ty - y)
            last_before_visit = (
                ctx.action_index + 1 < len(actions) and actions[ctx.action_index + 1].name != "move"
            )
            if not last_before_visit and d <= WAYPOINT_REACH:
                self._advance(ctx)
                continue
            ctx.current_action = action.pddl
            speed = arrive_speed(d) if last_before_visit else CRUISE_SPEED
            if last_before_visit and d <= 0.02:
                self._advance(ctx)
                continue
            steer(ctx, tx, ty, speed)
            return Status.RUNNING
        if ctx.remaining_goals():
            ctx.trigger = NoProgress(
                ctx.current_action, "plan finished before the goals were reached"
            )
            return Status.FAILURE
        return Status.RUNNING

    @staticmethod
    def _advance(ctx: MissionContext) -> None:
        ctx.action_index += 1
        ctx.progress_best, ctx.progress_since = math.inf, ctx.t

    def _reactive(self, ctx: MissionContext) -> Status:
        left = ctx.remaining_goals()
        if not left or not ctx.reactive_steps:
            return Status.RUNNING
        goal = ctx.goals[left[0]]
        x, y, _ = ctx.pose
        to_goal = math.atan2(goal.y - y, goal.x - x)
        step = ctx.reactive_steps[0]
        ctx.current_action = f"move({step.operator}: {step.relative_angle:+.0f} deg, {step.shape})"
        if step.operator == "PO1":
            steer(ctx, goal.x, goal.y, arrive_speed(goal.distance(x, y)))
            return Status.RUNNING
        side = to_goal + math.radians(step.relative_angle)
        if blocked_towards(ctx, side):
            ctx.trigger = ObstacleSensed(_marker(ctx))
            return Status.FAILURE
        if blocked_towards(ctx, to_goal):
            ctx.reactive_cleared = 0.0
        else:
            ctx.reactive_cleared += CRUISE_SPEED * ctx.interval
            if ctx.reactive_cleared >= REACTIVE_CLEARANCE:
                ctx.reactive_steps.pop(0)  # effect reached: obstacle(togoal) = F
                ctx.reactive_cleared = 0.0
                return self._reactive(ctx)
        steer(ctx, x + math.cos(side), y + math.sin(side), CRUISE_SPEED)
        return Status.RUNNING


class Replan(MissionBehaviour):
    """Plans (first plan or after a trigger), records the replan, and fails with a reason
    when no plan exists or the replan budget is spent."""

    def update(self) -> Status:
        ctx = self.ctx
        if ctx.failure is not None:
            return Status.FAILURE
        if sum(1 for r in ctx.replans if r.trigger != "initial") >= ctx.spec.max_replans:
            ctx.failure = f"gave up after {ctx.spec.max_replans} replans"
            return Status.FAILURE
        trigger = ctx.trigger or Initial()
        if ctx.spec.planner.domain == "reactive":
            return self._reactive(ctx, trigger)
        assert ctx.replanner is not None
        left = ctx.remaining_goals()
        x, y, psi = ctx.pose
        goals = tuple(Goal(ctx.goals[i].x, ctx.goals[i].y, ctx.goals[i].tolerance) for i in left)
        ctx.goal_map = left
        ctx.knowledge = replace(ctx.knowledge.moved((x, y, psi)), goals=goals, shape=ctx.shape)
        plan, record = ctx.replanner.plan(ctx.knowledge, trigger, at=round(ctx.t, 3))
        self._record(ctx, record, *ctx.replanner.planner.export(), plan.pddl_plan)
        if not plan.result.solved:
            ctx.failure = f"planning {plan.result.status}: {plan.result.reason}"
            return Status.FAILURE
        ctx.plan, ctx.action_index = plan, 0
        return Status.RUNNING

    def _reactive(self, ctx: MissionContext, trigger: object) -> Status:
        left = ctx.remaining_goals()
        goal = ctx.goals[left[0]]
        x, y, _ = ctx.pose
        to_goal = math.atan2(goal.y - y, goal.x - x)
        state = ReactiveState(
            False,
            blocked_towards(ctx, to_goal),
            blocked_towards(ctx, to_goal + math.pi / 2),
            blocked_towards(ctx, to_goal - math.pi / 2),
        )
        spec = ctx.spec.planner
        result, steps = plan_reactive(
            state,
            ctx.shape,
            spec.search,
            "hff" if spec.heuristic == "roadmap" else spec.heuristic,
            spec.time_limit,
        )
        from domain.triggers import ReplanRecord

        kind = getattr(trigger, "kind", "initial")
        detail = trigger.detail() if hasattr(trigger, "detail") else {}
        old = [f"({s.operator.lower()} {s.shape})" for s in ctx.reactive_steps]
        record = ReplanRecord(
            kind, detail, round(ctx.t, 3), result.search_ms, old, result.plan, result.status
        )
        problem = reactive_problem(state, ctx.shape).text()
        self._record(ctx, record, reactive_domain().text(), problem, result.plan)
        if not result.solved:
            ctx.failure = f"planning {result.status}: boxed in ({result.reason})"
            return Status.FAILURE
        ctx.reactive_steps, ctx.reactive_cleared = steps, 0.0
        return Status.RUNNING

    @staticmethod
    def _record(
        ctx: MissionContext, record: object, domain: str, problem: str, plan: list[str]
    ) -> None:
        from domain.triggers import ReplanRecord

        assert isinstance(record, ReplanRecord)
        ctx.replans.append(record)
        ctx.plan_version += 1
        ctx.pddl.append(
            {"version": ctx.plan_version, "domain": domain, "problem": problem, "plan": plan}
        )
        ctx.trigger = None
        ctx.progress_best, ctx.progress_since = math.inf, ctx.t
        if record.trigger != "initial":
            ctx.event(
                "replan",
                trigger=record.trigger,
                latency_ms=round(record.latency_ms, 3),
                version=ctx.plan_version,
            )

"""py_trees behaviours of the mission tree: sensing, guards, execution and replanning.

Behaviours decide; they never move the robot. Each tick the tree leaves a command (screw
speeds and joints for one control tick) on the mission context, and the runner sends it
through the Robot port. ``Sense`` turns the latest observation into the world model; guards
check the body shape and the plan's preconditions; ``Execute`` asks the planning strategy for
the next command; a guard or execution that cannot go on leaves a typed trigger and fails,
which hands control to ``Replan``. No behaviour branches on the planner kind: the strategy
owns its plan.
"""

from __future__ import annotations

import math

import numpy as np
from py_trees.common import Access, Status

from app.executor.context import MissionContext
from app.executor.light import LightBehaviour
from app.executor.plan_versions import PlanVersion, settle
from app.executor.robot import ContactReading
from app.missions.spec import ARRIVE_FRACTION
from domain.strategy import Command
from domain.triggers import Contact, Initial, NoProgress, ShapeChanged, Trigger
from primitives.shapes import SHAPES
from sim.obstacles import point_segment_distance
from sim.robot import DEFAULT_GEOMETRY, Array, joint_positions, rotate
from sim.world import footprint

SHAPE_TOLERANCE = 0.1  # rad: sensed joints further than this from the commanded ones: deformed
NO_PROGRESS_TIME = 150.0  # model seconds without 5 cm of progress towards the next goal
CONTACT_STANDOFF = 0.02  # metres beyond the touching unit's surface where the contact is marked
CONTACT_EXTENT = 0.1  # metres a side contact is marked beyond each end of the touching unit
SUSPECT_EXTENT = 0.6  # metres further the touched surface is suspected to go on (plans avoid
# it while they can; beams that see it free clear it) ...
SUSPECT_ANGLE = math.radians(30)  # ... at up to this angle to the touching part, ...
SUSPECT_DEPTH = 0.1  # ... and no deeper into the touched side than this (a thin wall's far
# side, where a goal may lie, is not suspected)


class MissionBehaviour(LightBehaviour):
    """A behaviour reading the mission context from its blackboard namespace (once: the
    context is one object for the whole mission, and behaviours read it every tick)."""

    def __init__(self, name: str, namespace: str) -> None:
        super().__init__(name)
        self.bb = self.attach_blackboard_client(name=name, namespace=namespace)
        self.bb.register_key("context", access=Access.READ)
        self._ctx: MissionContext | None = None

    @property
    def ctx(self) -> MissionContext:
        if self._ctx is None:
            self._ctx = self.bb.context
        return self._ctx

    def fail(self, trigger: Trigger, message: str) -> Status:
        self.ctx.trigger = trigger
        self.feedback_message = message
        return Status.FAILURE


Points = list[tuple[float, float]]


def contact_points(ctx: MissionContext, contact: ContactReading) -> tuple[Points, Points]:
    """Where the touched thing is, and where it probably goes on. It is just outside the
    reported side of the reported part: a side bumper spans its unit, so the obstacle is marked
    along the whole side and a little beyond (what presses a side is mostly a wall or an edge,
    seldom a point); an end bumper marks the point on its axis, the rest of the end's width
    suspected. The surface is suspected to continue
    ``SUSPECT_EXTENT`` further, both ways, at up to ``SUSPECT_ANGLE`` to the part."""
    x, y, psi = ctx.pose
    pts = joint_positions(np.array([x, y, psi]), np.asarray(ctx.sensed_joints()))
    g = DEFAULT_GEOMETRY
    if contact.part == 0:
        front, rear, radius = (
            pts[0] + g.head_length * np.array([-math.cos(psi), -math.sin(psi)]),
            pts[0],
            g.head_radius,
        )
    else:
        front, rear, radius = pts[contact.part - 1], pts[contact.part], g.unit_radius
    axis = front - rear
    forward = axis / max(float(np.linalg.norm(axis)), 1e-9)
    left = np.array([-forward[1], forward[0]])
    middle = (front + rear) / 2
    reach = radius + CONTACT_STANDOFF
    if contact.side in ("front", "rear"):
        sign = 1.0 if contact.side == "front" else -1.0
        centre = (front if sign > 0 else rear) + sign * reach * forward
        direction, half, outward = left, radius, sign * forward
    else:
        outward = left if contact.side == "left" else -left
        centre = middle + reach * outward
        direction, half = forward, float(np.linalg.norm(axis)) / 2 + CONTACT_EXTENT

    def line(a: float, b: float, along: Array) -> Array:
        steps = np.linspace(a, b, max(2, math.ceil(abs(b - a) / 0.025) + 1))
        out: Array = centre + steps[:, None] * along
        return out

    # The surface touched at an unknown angle to the part: a fan of lines through the contact,
    # on the touched side of the body and off the body itself (where the body is, is free).
    beyond = half + SUSPECT_EXTENT
    fan = np.concatenate(
        [
            line(-beyond, beyond, rotate(direction, np.array(a)))
            for a in np.linspace(-SUSPECT_ANGLE, SUSPECT_ANGLE, 5)
        ]
    )
    fp = footprint(np.array([x, y, psi]), np.asarray(ctx.sensed_joints()), g)
    off_body = (
        np.min(point_segment_distance(fan[:, None, :], fp.starts, fp.ends) - fp.radii, axis=-1)
        > 0.03
    )
    depth = (fan - centre) @ outward  # how far into the touched side
    suspected = fan[off_body & (depth >= -0.01) & (depth <= SUSPECT_DEPTH)]
    if contact.side in ("front", "rear"):
        # An end bumper felt one point of its cap, somewhere within 45 degrees of the axis:
        # only the axis point is taken as certain; the rest of the cap's width is suspected.
        # Marking the whole width blocked passages the real obstacle leaves open (a post just
        # off a corridor's exit, touched by the tail on the way out).
        touched = centre[None, :]
        suspected = np.concatenate([suspected, line(-half, half, direction)])
    else:
        touched = line(-half, half, direction)
    return [(float(p[0]), float(p[1])) for p in touched], [
        (float(p[0]), float(p[1])) for p in suspected
    ]


class Sense(MissionBehaviour):
    """The observation into the world model: range readings, the contact sensor, dropouts."""

    def update(self) -> Status:
        ctx = self.ctx
        obs = ctx.observation
        fresh = ctx.world.integrate(r for _, r in obs.ranges)
        if fresh:
            ctx.event("obstacle_sensed", cells=len(fresh))
        if obs.contact is not None and getattr(self, "_seen", None) != (obs.t, obs.contact):
            self._seen = (obs.t, obs.contact)
            ctx.contacts += 1
            marks, suspected = contact_points(ctx, obs.contact)
            for point in marks:
                ctx.world.add_contact(point)
            ctx.world.add_suspected(suspected)
            at = marks[len(marks) // 2]
            ctx.event("collision", part=obs.contact.part, side=obs.contact.side, at=list(at))
            return self.fail(
                Contact(obs.contact.part, obs.contact.side, at),
                f"part {obs.contact.part} touched something on its {obs.contact.side} side",
            )
        if ctx.trigger is not None:
            return Status.FAILURE
        self.feedback_message = f"world model v{ctx.world.version}"
        return Status.SUCCESS


class ShapeGuard(MissionBehaviour):
    """The joint-angle sensors against the commanded shape: a deformation changes the shape."""

    def update(self) -> Status:
        ctx = self.ctx
        a, b, c = sensed = ctx.observation.joints  # three floats: compared as such, every tick
        finite = math.isfinite
        if not (finite(a) and finite(b) and finite(c)) or SHAPES[ctx.shape].periodic:
            return Status.SUCCESS  # no reading (dropout), or the gait moves the joints on purpose
        ca, cb, cc = ctx.joints
        if max(abs(a - ca), abs(b - cb), abs(c - cc)) <= SHAPE_TOLERANCE:
            return Status.SUCCESS
        joints = (float(sensed[0]), float(sensed[1]), float(sensed[2]))
        coverage = ctx.library.covers(joints)
        rounded = [round(v, 2) for v in joints]
        if coverage.shape is None:
            ctx.failure = (
                f"body shape {rounded} has no primitives in the library ({coverage.describe()})"
            )
            self.feedback_message = ctx.failure
            return Status.FAILURE
        # The body holds what it was forced into: compare against that from now on. A shape
        # covered by interpolation runs its nearest library shape's primitives, joints held.
        shape = coverage.shape
        ctx.shape, ctx.joints, ctx.deformed = shape, joints, True
        ctx.event("deform", joints=rounded, shape=shape, coverage=coverage.to_dict())
        return self.fail(ShapeChanged(shape, joints), f"deformed into {shape}")


class PlanGuard(MissionBehaviour):
    """A plan exists and its next steps still hold in the world model."""

    def update(self) -> Status:
        ctx = self.ctx
        if not ctx.have_plan or ctx.strategy is None:
            self.feedback_message = "no plan"
            return Status.FAILURE
        trigger = ctx.strategy.broken(ctx.situation())
        if trigger is not None:
            return self.fail(trigger, f"plan broken: {trigger.kind}")
        return Status.SUCCESS


class Execute(MissionBehaviour):
    """One tick of the plan: the strategy's command for the next control tick."""

    def update(self) -> Status:
        ctx = self.ctx
        assert ctx.strategy is not None
        outcome = ctx.strategy.command(ctx.situation())
        if outcome is None:
            if ctx.remaining_goals():
                return self.fail(
                    NoProgress(ctx.current_action, "plan finished before the goals were reached"),
                    "plan finished early",
                )
            return Status.RUNNING
        if not isinstance(outcome, Command):
            return self.fail(outcome, f"execution stopped: {outcome.kind}")
        ctx.command = outcome.control
        joints = getattr(outcome.control, "joints", None)
        if outcome.shape is not None and not ctx.deformed and joints is not None:
            # The strategy runs a primitive of this shape: the body takes (or keeps) it.
            if outcome.shape != ctx.shape:
                ctx.event("shape_change", shape=outcome.shape, previous=ctx.shape)
                ctx.shape = outcome.shape
            ctx.joints = (float(joints[0, 0]), float(joints[0, 1]), float(joints[0, 2]))
        ctx.current_action = outcome.action
        ctx.grounding = outcome.grounding
        self.feedback_message = ctx.current_action
        return Status.RUNNING


class GoalsReached(MissionBehaviour):
    """Marks goals the tracked point is on (the next one in given order, any in any order);
    SUCCESS once all are reached. Also ends a mission that stopped making progress."""

    def initialise(self) -> None:
        self.best, self.since = math.inf, 0.0

    def update(self) -> Status:
        ctx = self.ctx
        x, y, _ = ctx.pose
        left = ctx.remaining_goals()
        candidates = left[:1] if ctx.spec.order == "given" else left
        for i in candidates:
            g = ctx.goals[i]
            if g.distance(x, y) <= ARRIVE_FRACTION * g.tolerance:
                ctx.mark_reached(i)
                self.best, self.since = math.inf, ctx.t
        left = ctx.remaining_goals()
        if not left:
            self.feedback_message = "all goals reached"
            return Status.SUCCESS
        d = min(ctx.goals[i].distance(x, y) for i in left)
        if d < self.best - 0.05:
            self.best, self.since = d, ctx.t
        elif ctx.t - self.since > NO_PROGRESS_TIME:
            ctx.failure = (
                f"no progress: {NO_PROGRESS_TIME:g} model s without getting 5 cm closer to "
                f"goal {left[0]}"
            )
            self.feedback_message = ctx.failure
            return Status.FAILURE
        self.feedback_message = f"{len(left)} goals left"
        return Status.FAILURE


class Replan(MissionBehaviour):
    """Plans (first plan or after a trigger), records it, and fails with the strategy's reason
    when no plan exists or the replan budget is spent."""

    def update(self) -> Status:
        ctx = self.ctx
        if ctx.failure is not None:
            return Status.FAILURE
        if ctx.strategy is None:
            ctx.failure = "this mission has no planner"
            return Status.FAILURE
        if sum(1 for r in ctx.replans if r.trigger != "initial") >= ctx.spec.max_replans:
            ctx.failure = f"no progress: gave up after {ctx.spec.max_replans} replans"
            return Status.FAILURE
        trigger = ctx.trigger or Initial()
        out = ctx.strategy.replan(ctx.situation(), trigger, ctx.cancel)
        ctx.replans.append(out.record)
        ctx.plan_version += 1
        ctx.pddl.append(PlanVersion(ctx.plan_version, out))
        settle(ctx.pddl, ctx.searches_kept)
        ctx.trigger = None
        if out.record.trigger != "initial":
            # The log keeps the record without its plans (those are the plan versions); the
            # websocket's replan event adds them (old, new) to these same fields.
            record = out.record.to_dict()
            ctx.event(
                "replan",
                trigger=record["trigger"],
                detail=record["detail"],
                latency_ms=record["latency_ms"],
                status=record["status"],
                version=ctx.plan_version,
            )
        if not out.ok:
            ctx.have_plan = False
            ctx.failure = out.reason
            self.feedback_message = out.reason
            return Status.FAILURE
        ctx.have_plan = True
        self.feedback_message = f"plan v{ctx.plan_version}: {len(out.plan)} steps"
        return Status.RUNNING

"""py_trees behaviours of the mission tree: sensing, guards, planning and following the plan.

Behaviours decide; they never move the robot. Each tick the tree leaves a command (screw
speeds and joints for one control tick) on the mission context, and the runner sends it
through the Robot port. ``Sense`` turns the latest observation into the world model; the
guards check progress, the body shape and the plan; ``Plan`` plans when there is no plan or
a trigger is pending; ``Execute`` asks the planning strategy for the next command. A failure
to plan or to follow the plan (a contact) fails the follower, which hands control to the
recoveries (``app/executor/recoveries.py``). No behaviour branches on the planner kind: the
strategy owns its plan.
"""

from __future__ import annotations

import math

from py_trees.common import Access, Status

from app.executor.context import MissionContext
from app.executor.learning import lattice_shape
from app.executor.light import LightBehaviour
from app.executor.plan_versions import PlanVersion, settle
from app.missions.spec import ARRIVE_FRACTION
from domain.strategy import Command
from domain.triggers import Contact, Initial, NoProgress, ShapeChanged, Trigger
from primitives.shapes import shape_named


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

    def trigger(self, trigger: Trigger) -> None:
        """Leave a trigger for the next replan (a pending one replans too, first come)."""
        if self.ctx.trigger is None:
            self.ctx.trigger = trigger


class Sense(MissionBehaviour):
    """The observation into the world model: range readings, the body's own cells, the
    contact sensor (its evidence, and a contact for the recoveries), fading evidence."""

    def update(self) -> Status:
        ctx = self.ctx
        obs = ctx.observation
        world = ctx.world
        world.advance(obs.t)
        fresh = world.integrate(r for _, r in obs.ranges)
        world.observe_body(obs.pose, ctx.sensed_joints())
        if fresh:
            ctx.event("obstacle_sensed", cells=len(fresh))
        if obs.contact is not None and self._seen != (obs.t, obs.contact):
            self._seen = (obs.t, obs.contact)
            ctx.contacts += 1
            part, side = obs.contact.part, obs.contact.side
            points = world.add_contact(obs.pose, ctx.sensed_joints(), part, side, obs.t)
            x, y = (float(v) for v in points[len(points) // 2])
            at = (round(x, 4), round(y, 4))
            ctx.event("collision", part=part, side=side, at=list(at), action=ctx.current_action)
            ctx.contact = obs.contact
            ctx.failure_reason = f"part {part} touched something on its {side} side"
            self.trigger(Contact(part, side, at))
        self.feedback_message = f"world model v{world.version}.{world.soft_version}"
        return Status.SUCCESS

    _seen: object = None


class ProgressGuard(MissionBehaviour):
    """Ends the mission when it stops making progress (Nav2's progress checker): the body has
    not moved ``progress_radius`` metres in ``no_progress_time`` model seconds, or the
    mission's replan budget is spent. Moving away from a goal is progress: a way out of a
    trap leads away first."""

    anchor: tuple[float, float, float] | None = None  # where the robot last counted as moving
    since = 0.0

    def update(self) -> Status:
        ctx = self.ctx
        replans = sum(1 for r in ctx.replans if r.trigger != "initial")
        if replans >= ctx.spec.max_replans:
            ctx.failure = f"no progress: gave up after {ctx.spec.max_replans} replans"
            self.feedback_message = ctx.failure
            return Status.FAILURE
        follow = ctx.settings.follow
        x, y, psi = ctx.pose
        anchor = self.anchor
        moved = anchor is None or (
            math.hypot(x - anchor[0], y - anchor[1]) > follow.progress_radius
            or abs(math.remainder(psi - anchor[2], 2 * math.pi)) > follow.progress_turn
        )
        if moved:
            self.anchor, self.since = (x, y, psi), ctx.t
        elif ctx.t - self.since > follow.no_progress_time:
            ctx.failure = (
                f"no progress: the body moved less than {follow.progress_radius:g} m in "
                f"{follow.no_progress_time:g} model s"
            )
            self.feedback_message = ctx.failure
            return Status.FAILURE
        self.feedback_message = f"moving (last {ctx.t - self.since:.0f} s ago)"
        return Status.SUCCESS


class ShapeGuard(MissionBehaviour):
    """The joint-angle sensors against the commanded shape: a deformation changes the shape
    (and replans); on the lattice, a shape without a lattice shape within the tolerance is
    learned first (by the runner, in this tick); elsewhere a shape the library has no
    primitives for ends the mission."""

    def update(self) -> Status:
        ctx = self.ctx
        a, b, c = sensed = ctx.observation.joints  # three floats: compared as such, every tick
        finite = math.isfinite
        if not (finite(a) and finite(b) and finite(c)) or shape_named(ctx.shape).periodic:
            self.feedback_message = f"{ctx.shape} (joints not read)"
            return Status.SUCCESS  # no reading (dropout), or the gait moves the joints on purpose
        if ctx.reshaping:
            self.feedback_message = f"{ctx.shape}: changing shape as commanded"
            return Status.SUCCESS
        ca, cb, cc = ctx.joints
        if max(abs(a - ca), abs(b - cb), abs(c - cc)) <= ctx.settings.follow.shape_tolerance:
            self.feedback_message = f"{ctx.shape} as commanded"
            return Status.SUCCESS
        joints = (float(sensed[0]), float(sensed[1]), float(sensed[2]))
        rounded = [round(v, 2) for v in joints]
        if ctx.on_lattice:
            return self._on_lattice(joints, rounded)
        coverage = ctx.library.covers(joints)
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
        ctx.trigger = ShapeChanged(shape, joints)  # replans at once, whatever was pending
        self.feedback_message = f"deformed into {shape}"
        return Status.SUCCESS

    def _on_lattice(self, joints: tuple[float, float, float], rounded: list[float]) -> Status:
        ctx = self.ctx
        shape, learn = lattice_shape(ctx.library, joints, ctx.learning_settings)
        cover = ctx.library.lattice_covers(joints, ctx.learning_settings.tolerance)
        ctx.shape, ctx.joints, ctx.deformed = shape, joints, True
        ctx.event("deform", joints=rounded, shape=shape, coverage=cover.to_dict())
        ctx.trigger = ShapeChanged(shape, joints)  # replans at once, on its lattice
        if learn:  # here, so the tick goes on as it would had the library had the shape
            assert ctx.learn_shape is not None
            why = ctx.learn_shape(joints)
            if why is not None:
                ctx.failure = self.feedback_message = why
                return Status.FAILURE
            self.feedback_message = f"deformed into {shape}, learned its lattice"
            return Status.SUCCESS
        self.feedback_message = f"deformed into {shape}"
        return Status.SUCCESS


class PlanGuard(MissionBehaviour):
    """The plan's next steps still hold in the world model (else a trigger to replan)."""

    def update(self) -> Status:
        ctx = self.ctx
        if not ctx.have_plan or ctx.strategy is None:
            self.feedback_message = "no plan yet"
            return Status.SUCCESS
        trigger = ctx.strategy.broken(ctx.situation())
        if trigger is not None:
            self.trigger(trigger)
            self.feedback_message = f"plan broken: {trigger.kind}"
        else:
            self.feedback_message = f"plan v{ctx.plan_version} holds"
        return Status.SUCCESS


class Plan(MissionBehaviour):
    """Plans when there is no plan or a trigger is pending (the first plan too), records it,
    and fails with the strategy's typed failure when there is none."""

    def update(self) -> Status:
        ctx = self.ctx
        if ctx.strategy is None:
            ctx.failure = "this mission has no planner"
            return Status.FAILURE
        if ctx.contact is not None:
            self.feedback_message = "a contact: recover first"
            return Status.FAILURE
        if ctx.have_plan and ctx.trigger is None:
            self.feedback_message = f"plan v{ctx.plan_version}"
            return Status.SUCCESS
        trigger = ctx.trigger or Initial()
        out = ctx.strategy.replan(ctx.situation(), trigger, ctx.cancel)
        ctx.replans.append(out.record)
        ctx.plan_version += 1
        ctx.pddl.append(PlanVersion(ctx.plan_version, out, ctx.strategy))
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
            ctx.plan_failure, ctx.plan_proof = out.failure, out.proof
            ctx.failure_reason = out.reason
            self.feedback_message = out.reason
            return Status.FAILURE
        ctx.have_plan = True
        ctx.plan_failure = ctx.plan_proof = ctx.failure_reason = None
        ctx.shapes_tried.clear()
        self.feedback_message = f"plan v{ctx.plan_version}: {len(out.plan)} steps"
        return Status.SUCCESS


class Execute(MissionBehaviour):
    """One tick of the plan: the strategy's command for the next control tick; a contact
    fails it (the recoveries take over)."""

    def update(self) -> Status:
        ctx = self.ctx
        if ctx.contact is not None:
            self.feedback_message = f"stopped: {ctx.failure_reason}"
            return Status.FAILURE
        assert ctx.strategy is not None
        outcome = ctx.strategy.command(ctx.situation())
        if outcome is None:
            if ctx.remaining_goals():
                self.trigger(
                    NoProgress(ctx.current_action, "the plan ended before the goals were reached")
                )
                self.feedback_message = "plan finished: plan again"
                ctx.have_plan = False
            return Status.RUNNING
        if not isinstance(outcome, Command):
            self.trigger(outcome)
            ctx.have_plan = False
            self.feedback_message = f"stopped: {outcome.kind}, plan again"
            return Status.RUNNING
        ctx.command = outcome.control
        joints = getattr(outcome.control, "joints", None)
        if outcome.shape is not None and not ctx.deformed and joints is not None:
            # The strategy runs a primitive of this shape: the body takes (or keeps) it, and
            # the shape guard compares the joint sensors with that, not with the last shape.
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
    SUCCESS once all are reached."""

    def update(self) -> Status:
        ctx = self.ctx
        x, y, _ = ctx.pose
        left = ctx.remaining_goals()
        candidates = left[:1] if ctx.spec.order == "given" else left
        for i in candidates:
            g = ctx.goals[i]
            if g.distance(x, y) <= ARRIVE_FRACTION * g.tolerance:
                ctx.mark_reached(i)
        left = ctx.remaining_goals()
        if not left:
            self.feedback_message = "all goals reached"
            return Status.SUCCESS
        self.feedback_message = f"{len(left)} goals left"
        return Status.FAILURE

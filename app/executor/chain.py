"""Manual chaining (paper §5.1, Figs. 9b, 11, 12): one behaviour per chain step.

A step runs a library primitive (or a bilinear interpolation of three, eqs. 16-18) until its
condition holds: a point reached, a duration, or a range sensor below/above a threshold. A step
with a ``heading`` first turns the body in place to it with its shape's library turns (the
shape change happens there), so the primitive then moves as it was learned from the start
pose. After a deformation the sensed shape's primitives take over towards the same direction
(Fig. 13b's IM4). A contact stops the chain with the part and side that touched.
"""

from __future__ import annotations

import math

import numpy as np
from py_trees.common import Status

from app.executor.behaviours import MissionBehaviour, ShapeGuard
from app.executor.context import MissionContext
from app.missions.spec import ChainStep
from primitives.grounding import correction_basis, ground
from primitives.interpolation import interpolate_entries, interpolate_in_shape
from primitives.shapes import shape_named
from sim.controls import FixedShape, PeriodicGait

REACH_TIMEOUT = 400.0  # model seconds a `reach` step may take
TURN_TOLERANCE = (math.radians(0.5), 0.01)  # a turn in place is done within 0.5° and 1 cm
TURN_TIMEOUT = 120.0  # model seconds a turn in place may take


class ChainShapeGuard(ShapeGuard):
    """In a manual chain a deformation only re-grounds the step: the guard never fails it."""

    def update(self) -> Status:
        status = super().update()
        ctx = self.ctx
        ctx.trigger = None
        if status == Status.FAILURE and ctx.failure is None:
            return Status.SUCCESS
        return status


class ChainStepBehaviour(MissionBehaviour):
    """Runs one manual chain step until its condition."""

    def __init__(self, name: str, namespace: str, index: int) -> None:
        super().__init__(name, namespace)
        self.index = index

    def initialise(self) -> None:
        ctx = self.ctx
        ctx.chain_started = ctx.t
        step = ctx.spec.chain[self.index]
        self.turning = step.heading is not None
        self.hold = ctx.pose[:2]

    def update(self) -> Status:
        ctx = self.ctx
        step = ctx.spec.chain[self.index]
        until = step.until
        contact = ctx.observation.contact
        if contact is None and self.turning:
            if self._turn(ctx, step):
                return Status.RUNNING
            self.turning = False
            ctx.chain_started = ctx.t  # the step's own conditions count from here
        elapsed = ctx.t - ctx.chain_started
        if contact is not None and elapsed > 0:
            ctx.contacts += 1
            ctx.event("collision", part=contact.part, side=contact.side)
            ctx.failure = (
                f"chain step {self.index} stopped: part {contact.part} touched something on "
                f"its {contact.side} side"
            )
            return Status.FAILURE
        x, y, _ = ctx.pose
        if (
            until.reach is not None
            and math.hypot(until.reach.x - x, until.reach.y - y) <= until.reach.tolerance
        ):
            return Status.SUCCESS
        if until.duration is not None and elapsed >= until.duration - 1e-9:
            return Status.SUCCESS
        if until.sensor is not None:
            reading = ctx.observation.range_of(until.sensor)
            if (until.below is not None and reading < until.below) or (
                until.above is not None and reading > until.above
            ):
                return Status.SUCCESS
            if until.timeout is not None and elapsed >= until.timeout - 1e-9:
                return Status.SUCCESS
        if until.reach is not None and elapsed > REACH_TIMEOUT:
            ctx.failure = (
                f"chain step {self.index} did not reach ({until.reach.x:g}, {until.reach.y:g}) "
                f"within {REACH_TIMEOUT:g} model s"
            )
            return Status.FAILURE
        self._command(ctx, step)
        return Status.RUNNING

    def _step_shape(self, ctx: MissionContext, step: ChainStep) -> str:
        if step.primitive is not None:
            return ctx.library.get(step.primitive).shape
        assert step.interpolate is not None
        return ctx.library.get(step.interpolate.from_[0]).shape

    def _turn(self, ctx: MissionContext, step: ChainStep) -> bool:
        """One tick of turning in place to ``step.heading`` about the tracked point; False once
        there. Library turns and translations of the step's shape (the body takes that shape
        here; a periodic step turns straight) blended by their recorded motions."""
        assert step.heading is not None
        x, y, psi = ctx.pose
        turn = math.remainder(math.radians(step.heading) - psi, 2 * math.pi)
        dx, dy = self.hold[0] - x, self.hold[1] - y
        local = (
            math.cos(psi) * dx + math.sin(psi) * dy,
            -math.sin(psi) * dx + math.cos(psi) * dy,
        )
        if abs(turn) <= TURN_TOLERANCE[0] and math.hypot(*local) <= TURN_TOLERANCE[1]:
            return False
        if ctx.t - ctx.chain_started > TURN_TIMEOUT:
            return False  # the step runs from the heading it got to; the log shows it
        shape = self._step_shape(ctx, step)
        if not ctx.library.lattice(shape) or ctx.deformed:
            shape = ctx.shape if ctx.library.lattice(ctx.shape) else "straight"
        basis = correction_basis(ctx.library.lattice(shape))
        if not basis:
            return False
        grounded = ground((local[0], local[1], turn), basis)
        joints = np.asarray(ctx.joints if ctx.deformed else shape_named(shape).joints)
        self._set_shape(ctx, shape)
        ctx.current_action = f"turn to {step.heading:g} deg (chain step {self.index})"
        ctx.grounding = grounded.to_dict()
        ctx.joints = (float(joints[0]), float(joints[1]), float(joints[2]))
        ctx.command = FixedShape.of(grounded.theta, joints)
        return True

    @staticmethod
    def _set_shape(ctx: MissionContext, shape: str) -> None:
        """The commanded body shape, logged when the chain changes it."""
        if ctx.deformed or shape == ctx.shape:
            return
        ctx.event("shape_change", shape=shape, previous=ctx.shape)
        ctx.shape = shape

    def _command(self, ctx: MissionContext, step: ChainStep) -> None:
        if step.primitive is not None:
            entry = ctx.library.get(step.primitive)
            if entry.periodic:
                self._set_shape(ctx, entry.shape)
                ctx.current_action = f"{entry.name} (chain step {self.index})"
                ctx.grounding = {"method": "library", "primitives": [entry.id]}
                ctx.command = PeriodicGait.of(
                    entry.theta, entry.phases or (0, 0, 0), t0=ctx.chain_started
                )
                return
            theta, joints = np.array(entry.theta), np.array(entry.joints or (0, 0, 0))
            goal, sources, method = entry.goal, [entry.id], "library"
            shape = entry.shape
        else:
            assert step.interpolate is not None
            entries = [ctx.library.get(n) for n in step.interpolate.from_]
            made = interpolate_entries(entries, step.interpolate.goal)
            theta, joints = made.theta, made.joints
            goal, sources, method = step.interpolate.goal, [e.id for e in entries], "interpolated"
            shape = entries[0].shape
        if not ctx.deformed:
            self._set_shape(ctx, shape)
        elif ctx.shape != shape and not shape_named(ctx.shape).periodic:
            # The body cannot hold these joints: the sensed shape's primitives, same direction.
            scale = 2.0 / max(math.hypot(*goal), 1e-9)
            made = interpolate_in_shape(ctx.library, (goal[0] * scale, goal[1] * scale), ctx.shape)
            theta, joints = made.theta, made.joints
            sources, method = list(made.sources), "interpolated"
        ctx.current_action = f"{'/'.join(sources)} (chain step {self.index})"
        ctx.grounding = {"method": method, "primitives": sources}
        ctx.joints = (float(joints[0]), float(joints[1]), float(joints[2]))
        ctx.command = FixedShape.of(theta, joints)

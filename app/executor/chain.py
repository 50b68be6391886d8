"""Manual chaining (paper §5.1, Figs. 9b, 11, 12): one behaviour per chain step."""

from __future__ import annotations

import math

import numpy as np
from py_trees.common import Status

from app.executor.behaviours import CRUISE_SPEED, MissionBehaviour, steer
from app.executor.context import MissionContext
from app.missions.spec import ChainStep
from primitives.interpolation import interpolate_entries
from sim.controls import FixedShape, PeriodicGait
from sim.rollout import RolloutConfig, rollout


class ChainStepBehaviour(MissionBehaviour):
    """Runs one manual chain step (a library primitive or an interpolation) until its condition."""

    def __init__(self, name: str, namespace: str, index: int) -> None:
        super().__init__(name, namespace)
        self.index = index

    def initialise(self) -> None:
        ctx = self.ctx
        ctx.chain_started = ctx.t

    def update(self) -> Status:
        ctx = self.ctx
        step = ctx.spec.chain[self.index]
        until = step.until
        elapsed = ctx.t - ctx.chain_started
        x, y, _ = ctx.pose
        if (
            until.reach is not None
            and math.hypot(until.reach.x - x, until.reach.y - y) <= until.reach.tolerance
        ):
            return Status.SUCCESS
        if until.duration is not None and elapsed >= until.duration - 1e-9:
            return Status.SUCCESS
        if until.sensor is not None:
            reading = ctx.readings.ranges.get(until.sensor, math.nan) if ctx.readings else math.nan
            if (until.below is not None and reading < until.below) or (
                until.above is not None and reading > until.above
            ):
                return Status.SUCCESS
            if until.timeout is not None and elapsed >= until.timeout - 1e-9:
                return Status.SUCCESS
        if until.reach is not None and elapsed > 400.0:
            ctx.failure = (
                f"chain step {self.index} did not reach ({until.reach.x:g}, {until.reach.y:g})"
            )
            return Status.FAILURE
        self._command(ctx, step)
        return Status.RUNNING

    def _command(self, ctx: MissionContext, step: ChainStep) -> None:
        if step.primitive is not None:
            entry = ctx.library.get(step.primitive)
            ctx.current_action = f"{entry.name} (chain step {self.index})"
            ctx.grounding = {"method": "library", "primitives": [entry.id]}
            if entry.periodic:
                ctx.command = PeriodicGait.of(
                    entry.theta, entry.phases or (0, 0, 0), t0=ctx.chain_started
                )
                return
            theta, joints = np.array(entry.theta), np.array(entry.joints or (0, 0, 0))
        else:
            assert step.interpolate is not None
            entries = [ctx.library.get(n) for n in step.interpolate.from_]
            made = interpolate_entries(entries, step.interpolate.goal)
            theta, joints = made.theta, made.joints
            ctx.current_action = f"IM({', '.join(made.sources)}) -> {step.interpolate.goal} (chain step {self.index})"
            ctx.grounding = {"method": "interpolated", "primitives": [e.id for e in entries]}
        if ctx.sim.deformed:  # the body cannot hold these joints: go the same way in the new shape
            x, y, psi = ctx.pose
            heading = psi + _first_motion(theta, joints)
            steer(ctx, x + math.cos(heading), y + math.sin(heading), CRUISE_SPEED)
            return
        ctx.command = FixedShape.of(theta, joints)


def _first_motion(theta: np.ndarray, joints: np.ndarray) -> float:
    """Direction (start frame) of a primitive's first second of motion."""
    end = rollout(FixedShape.of(theta, joints), config=RolloutConfig(1.0, 1.0)).end[0]
    return math.atan2(end[1], end[0])

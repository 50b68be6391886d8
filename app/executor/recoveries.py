"""Recoveries as behaviour-tree nodes, after Nav2's navigator trees.

Two composites py_trees lacks:

- ``RecoveryNode`` (Nav2's RecoveryNode): ticks its first child (following the plan); when that
  fails, ticks its second (the recoveries) and, once a recovery succeeds, the first again; it
  fails after ``retries`` recoveries in a row, or when no recovery applies. Recoveries count
  from zero again once the robot, following the plan, is ``settle_distance`` from where the last
  recovery left it (progress: backing off a contact and driving into it again is none).
- ``RoundRobin`` (Nav2's RoundRobin): each activation starts at the child after the one that
  ran last; a child that fails (or does not apply) hands on to the next; it fails when every
  child failed once.

And the recoveries, each a behaviour that applies to some failures and runs library motions
through the Robot port (``domain.navigation.recovery``): ``BackOff`` from a contact (or out of a
start where the body rests too close to something), ``SpinToSense`` (turn in place so the head's
rays look round), ``Reshape`` (another library shape whose lattice reaches the goals) and
``ClearStaleEvidence`` (forget contact evidence and sensed cells round the robot, then hold still
while the sensors read again). Each run is a ``recovery`` event in the mission's log.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np
import py_trees
from py_trees.common import Status

from app.executor.behaviours import MissionBehaviour
from app.executor.light import Selector
from domain import navigation
from domain.triggers import Recovered
from primitives.grounding import TICK, Grounded, ground
from primitives.library import Primitive
from primitives.shapes import shape_named


class RecoveryNode(py_trees.composites.Composite):
    """Runs ``pipeline``; on its failure runs ``recovery``, then ``pipeline`` again (see the
    module's docstring)."""

    def __init__(
        self,
        name: str,
        pipeline: py_trees.behaviour.Behaviour,
        recovery: py_trees.behaviour.Behaviour,
        retries: int,
        settle_distance: float,
        position: Callable[[], tuple[float, float]],
    ) -> None:
        super().__init__(name, [pipeline, recovery])
        self.retries, self.settle_distance, self.position = retries, settle_distance, position
        self.in_a_row = 0  # recoveries since the robot last got settle_distance from ...
        self.anchor: tuple[float, float] | None = None  # ... where the last one left it
        self.recovering = False

    def tick(self) -> Iterator[py_trees.behaviour.Behaviour]:
        if self.status != Status.RUNNING:
            self.in_a_row, self.anchor, self.recovering = 0, None, False
            self.initialise()
        pipeline, recovery = self.children
        while True:
            child = recovery if self.recovering else pipeline
            self.current_child = child
            yield from child.tick()
            if not self.recovering:
                if child.status == Status.SUCCESS:
                    self.stop(Status.SUCCESS)
                    yield self
                    return
                if child.status == Status.RUNNING:
                    if self.anchor is not None and self._moved() >= self.settle_distance:
                        self.in_a_row, self.anchor = 0, None  # progress
                    self._report(f"following; {self.in_a_row} recoveries in a row")
                    self.status = Status.RUNNING
                    yield self
                    return
                if self.in_a_row >= self.retries:
                    self._report(f"gave up after {self.in_a_row} recoveries in a row")
                    self.stop(Status.FAILURE)
                    yield self
                    return
                self.recovering = True
                continue  # the recoveries, in this same tick
            if child.status == Status.RUNNING:
                self._report(f"recovering ({self.in_a_row + 1} of at most {self.retries})")
                self.status = Status.RUNNING
                yield self
                return
            if child.status == Status.FAILURE:
                self._report("no recovery applies")
                self.stop(Status.FAILURE)
                yield self
                return
            self.in_a_row += 1
            self.anchor = self.position()
            self.recovering = False
            self._report(f"recovered; {self.in_a_row} recoveries in a row")
            self.status = Status.RUNNING  # the plan again on the next tick (re-ticked at once)
            yield self
            return

    def _moved(self) -> float:
        assert self.anchor is not None
        x, y = self.position()
        return float(np.hypot(x - self.anchor[0], y - self.anchor[1]))

    def _report(self, message: str) -> None:
        self.feedback_message = message

    def stop(self, new_status: Status = Status.INVALID) -> None:
        for child in self.children:
            if child.status == Status.RUNNING:
                child.stop(Status.INVALID)
        super().stop(new_status)


class RoundRobin(py_trees.composites.Composite):
    """Ticks its children in turn across activations (see the module's docstring)."""

    def __init__(self, name: str, children: Sequence[py_trees.behaviour.Behaviour]) -> None:
        super().__init__(name, list(children))
        self.next = 0
        self.tried = 0

    def tick(self) -> Iterator[py_trees.behaviour.Behaviour]:
        if self.status != Status.RUNNING:
            self.tried = 0
            self.initialise()
        while True:
            child = self.children[self.next]
            self.current_child = child
            yield from child.tick()
            if child.status == Status.RUNNING:
                self.feedback_message = f"running {child.name}"
                self.status = Status.RUNNING
                yield self
                return
            self.next = (self.next + 1) % len(self.children)
            if child.status == Status.SUCCESS:
                self.feedback_message = f"{child.name} done"
                self.stop(Status.SUCCESS)
                yield self
                return
            self.tried += 1
            if self.tried >= len(self.children):
                self.feedback_message = "none applies"
                self.stop(Status.FAILURE)
                yield self
                return

    def stop(self, new_status: Status = Status.INVALID) -> None:
        for child in self.children:
            if child.status == Status.RUNNING:
                child.stop(Status.INVALID)
        super().stop(new_status)


@dataclass
class _Step:
    """A motion a recovery runs: screw speeds and joints for a number of model seconds."""

    grounded: Grounded
    left: float
    label: str
    started: float | None = None  # model time of its first tick (a gait's clock)


class Recovery(MissionBehaviour):
    """A recovery: ``applies`` says whether it can help with the failure at hand (else it
    fails at once, and the next recovery is tried); ``steps`` are the motions it runs."""

    what = "recovery"

    def initialise(self) -> None:
        self.why = self.ctx.failure_reason or ""
        steps = self.plan() if self.applies() else None
        self.applicable = steps is not None
        self.steps: list[_Step] = steps or []
        self.ran = 0
        if self.applicable:
            self.ctx.event("recovery", recovery=self.name, because=self.why, moves=self.labels())

    def applies(self) -> bool:
        """Whether this recovery can help with the failure at hand."""
        raise NotImplementedError

    def plan(self) -> list[_Step] | None:
        """The motions to run (``None``: none can be made here, so it does not apply)."""
        raise NotImplementedError

    def done(self) -> None:
        """What the recovery does when its motions are over (before the plan runs again)."""

    def stopped_by_contact(self) -> None:
        """What the recovery learns from a contact stopping its motions."""

    def update(self) -> Status:
        ctx = self.ctx
        if not self.applicable:
            self.feedback_message = f"does not apply ({self.why or 'no failure'})"
            return Status.FAILURE
        if self.ran and ctx.contact is not None:
            self.feedback_message = "stopped by a contact"
            self.stopped_by_contact()
            self._finish("stopped by a contact")
            return Status.SUCCESS  # the plan's pipeline fails on the contact: back off next
        while self.steps and self.steps[0].left <= 1e-9:
            self.steps.pop(0)
        if not self.steps:
            self.done()
            self._finish("done")
            self.feedback_message = "done"
            return Status.SUCCESS
        step = self.steps[0]
        if step.started is None:
            step.started = ctx.t
        step.left -= TICK
        self.ran += 1
        g = step.grounded
        ctx.command = g.control(step.started)
        ctx.current_action = f"({self.what} {step.label})"
        ctx.grounding = g.to_dict()
        self.feedback_message = f"{step.label}: {step.left + TICK:.2f} s left"
        return Status.RUNNING

    def labels(self) -> list[str]:
        return [s.label for s in self.steps]

    def _finish(self, outcome: str) -> None:
        ctx = self.ctx
        ctx.trigger = Recovered(self.name, self.why)
        ctx.recoveries += 1
        ctx.event("recovery_done", recovery=self.name, outcome=outcome)

    @staticmethod
    def run(entry: Primitive) -> _Step:
        """A library primitive run as it is."""
        assert entry.end_pose is not None
        grounded = ground(entry.end_pose, [], entry)
        return _Step(grounded, grounded.duration, entry.id)


class BackOff(Recovery):
    """After a contact (or from a start the body rests too close to something): the shape's
    shortest translations away from the touched side (``back_off_steps`` of them). When none
    can be made after a contact, it still succeeds, having moved nothing: the plan is made
    again from where the body stopped (motions out of there may keep as close as it is)."""

    what = "back-off"
    STOPPED_KEPT = 8  # back-offs a contact stopped, remembered with where they began

    def __init__(self, name: str, namespace: str) -> None:
        super().__init__(name, namespace)
        # (where a back-off began, its first move) for those a contact stopped in that move:
        # from the same place (within the recoveries' settle distance) the move presses into
        # what the body touches, and the next back-off begins with another
        self.stopped: list[tuple[tuple[float, float], str]] = []
        self.began: tuple[float, float] = (0.0, 0.0)
        self.first: _Step | None = None  # the first move of the back-off under way

    def applies(self) -> bool:
        return self.ctx.contact is not None or self.ctx.plan_failure == "start_blocked"

    def plan(self) -> list[_Step] | None:
        ctx = self.ctx
        contact = ctx.contact
        ctx.contact = None  # dealt with here (a new one is a new contact)
        x, y = float(ctx.pose[0]), float(ctx.pose[1])
        near = ctx.settings.recovery.settle_distance
        moves = navigation.back_off(
            ctx.library,
            ctx.shape,
            ctx.joints,
            ctx.world,
            ctx.pose,
            contact.side if contact is not None else None,
            contact.part if contact is not None else None,
            ctx.settings,
            {m for (px, py), m in self.stopped if math.hypot(px - x, py - y) < near},
        )
        steps = [self.run(m) for m in moves]
        self.began, self.first = (x, y), steps[0] if steps else None
        if not moves:
            return [] if contact is not None else None
        return steps

    def stopped_by_contact(self) -> None:
        # (the first step itself, not its move's name: a back-off may repeat a move)
        if self.first is not None and self.steps and self.steps[0] is self.first:
            stopped = (self.began, self.first.label)
            self.stopped = [*self.stopped[-(self.STOPPED_KEPT - 1) :], stopped]


class SpinToSense(Recovery):
    """When planning found no way (it ran out of search, or sensed obstacles close it): the
    largest turn in place the body can make, the other way each time, so the head looks."""

    what = "spin"

    def applies(self) -> bool:
        failure = self.ctx.plan_failure
        return failure == "timeout" or (
            failure == "unreachable" and self.ctx.plan_proof == "sensed"
        )

    def plan(self) -> list[_Step] | None:
        ctx = self.ctx
        ctx.spin_direction = -ctx.spin_direction
        turn = navigation.spin(
            ctx.library, ctx.shape, ctx.joints, ctx.world, ctx.pose, ctx.settings,
            ctx.spin_direction,
        )  # fmt: skip
        return [self.run(turn)] if turn is not None else None


class Reshape(Recovery):
    """When the body's shape finds no plan: change into the nearest other library shape that
    can be taken here and whose lattice can reach every goal (never for a body the
    environment deformed: it holds what it was forced into)."""

    what = "reshape"

    def applies(self) -> bool:
        ctx = self.ctx
        return not ctx.deformed and ctx.plan_failure in ("unreachable", "timeout", "no_primitives")

    def plan(self) -> list[_Step] | None:
        ctx = self.ctx
        goals = ctx.situation().goals
        options = navigation.reshape_options(
            ctx.library, ctx.shape, ctx.joints, ctx.world, ctx.pose, goals, ctx.settings, ctx.view
        )
        options = [o for o in options if o not in ctx.shapes_tried]
        if not options:
            return None
        self.target = options[0]
        ctx.shapes_tried.add(ctx.shape)
        joints = np.asarray(shape_named(self.target).joints, dtype=float)
        duration = navigation.reshape_duration(
            ctx.joints, joints, TICK, ctx.settings.recovery.reshape_rate
        )
        change = Grounded(np.zeros(4), joints, duration, "library", (), np.zeros(3))
        ctx.reshaping = True  # the shape guard leaves the travelling joints alone
        return [_Step(change, duration, f"into {self.target}")]

    def terminate(self, new_status: Status) -> None:
        self.ctx.reshaping = False  # done, or interrupted: the guard compares again

    def done(self) -> None:
        ctx = self.ctx
        ctx.reshaping = False
        previous = ctx.shape
        ctx.shape = self.target
        a, b, c = (float(v) for v in shape_named(self.target).joints)
        ctx.joints = (a, b, c)
        ctx.event("shape_change", shape=self.target, previous=previous)


class ClearStaleEvidence(Recovery):
    """When sensed obstacles or contact evidence may be what closes the way: forget them round
    the robot (``clear_radius``), then hold still for ``wait_ticks`` while the sensors read
    again (what is real comes back). Once per set of goals left: what sensing finds again
    after a clear is real, and clearing it again would only lead the robot back into it."""

    what = "clear"

    def applies(self) -> bool:
        ctx = self.ctx
        failure = ctx.plan_failure
        return failure == "timeout" or (failure == "unreachable" and ctx.plan_proof == "sensed")

    def plan(self) -> list[_Step] | None:
        ctx = self.ctx
        left = tuple(ctx.remaining_goals())
        if left in ctx.cleared_for:
            return None  # cleared once for these goals already
        x, y, _ = ctx.pose
        if not ctx.world.clear_evidence((x, y), ctx.settings.recovery.clear_radius):
            return None  # nothing there to clear
        ctx.cleared_for.add(left)
        joints = np.asarray(ctx.joints, dtype=float)
        hold = Grounded(np.zeros(4), joints, 0.0, "library", (), np.zeros(3))
        ticks = ctx.settings.recovery.wait_ticks
        return [_Step(hold, ticks * TICK, "wait")] if ticks else []


def recovery_tree(ns: str) -> py_trees.behaviour.Behaviour:
    """Back off first when it applies (a contact), else the others in turn."""
    return Selector(
        "recover",
        memory=False,
        children=[
            BackOff("back off", ns),
            RoundRobin(
                "sense and retry",
                [
                    SpinToSense("spin to sense", ns),
                    Reshape("reshape", ns),
                    ClearStaleEvidence("clear stale evidence", ns),
                ],
            ),
        ],
    )


def robot_position(ns: str) -> Callable[[], tuple[float, float]]:
    """Where the mission's robot is (its tracked point), read from the context on ``ns``'s
    blackboard when asked: what ``RecoveryNode`` measures progress by."""
    reader = py_trees.blackboard.Client(name="robot position", namespace=ns)
    reader.register_key("context", access=py_trees.common.Access.READ)

    def position() -> tuple[float, float]:
        x, y, _ = reader.context.pose
        return float(x), float(y)

    return position

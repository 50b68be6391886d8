"""Closed-loop stepping simulator of one robot in a world: collisions, sensors, events.

Each ``step`` integrates one Euler step of the same kinematics as the batched rollouts and
sweeps the footprint along it in sub-steps no longer than ``check_step``, so the robot stops
at the last free pose before an obstacle and never passes through one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from sim.controls import Control, FixedShape, as_batch, check_joint_angles, clamp_joints
from sim.events import Deformation, Event, SensorDropout
from sim.robot import (
    DEFAULT_GEOMETRY,
    Array,
    NormalSolver,
    RobotGeometry,
    body_chain,
    body_twist,
    screw_rhs,
    shape_solver,
)
from sim.rollout import JOINT_MODES, JointMode
from sim.sensors import SensorReadings, SensorSuite
from sim.world import Contact, World, footprint, footprint_of_chain

TWISTS_KEPT = 256  # body twists remembered per simulator (screw speeds and shapes met)


@dataclass(frozen=True)
class EventRecord:
    """Something that happened during a step, for logs and the API."""

    t: float
    kind: str  # "deform", "dropout", "collision"
    detail: dict[str, object]


@dataclass(frozen=True)
class StepResult:
    t: float
    pose: Array
    joints: Array
    readings: SensorReadings
    contact: Contact | None
    events: tuple[EventRecord, ...]


@dataclass
class Simulator:
    """One robot in ``world``; ``reset`` then ``step(control)`` once per ``dt`` model seconds."""

    world: World = field(default_factory=World)
    geometry: RobotGeometry = DEFAULT_GEOMETRY
    sensors: SensorSuite = field(default_factory=SensorSuite)
    events: tuple[Event, ...] = ()
    dt: float = 0.5
    joint_mode: JointMode = "paper"
    check_step: float = 0.02  # metres a footprint point may move between collision checks

    def __post_init__(self) -> None:
        if not (math.isfinite(self.dt) and self.dt > 0):
            raise ValueError("dt: must be positive and finite")
        if not (math.isfinite(self.check_step) and self.check_step > 0):
            raise ValueError("check_step: must be positive and finite")
        if self.joint_mode not in JOINT_MODES:
            raise ValueError(f"joint_mode: must be one of {JOINT_MODES}")
        self.events = tuple(sorted(self.events, key=lambda e: e.t))
        self.reset(check=False)  # a state to start from; callers reset to their own pose

    # -- state ------------------------------------------------------------------------------
    def reset(
        self,
        pose: ArrayLike = (0.0, 0.0, 0.0),
        joints: ArrayLike = (0.0, 0.0, 0.0),
        seed: int | None = None,
        check: bool = True,
    ) -> SensorReadings:
        p = as_batch(pose, 3, "pose")[0]
        j = as_batch(joints, 3, "joints")
        check_joint_angles(j, self.geometry)
        self.t = 0.0
        self.pose = p.copy()
        self.joints = clamp_joints(j, self.geometry)[0]
        self.forced: Array | None = None
        self._twists: dict[bytes, Array] = {}  # body_twist by screw speeds and shape
        self._solvers: dict[bytes, NormalSolver] = {}  # its solver by shape (the shape is held)
        self._bodies: list[tuple[bytes, Array]] = []
        self.dropouts: list[SensorDropout] = []
        self.pending = list(self.events)
        self.collisions = 0
        self.initial_events = self._fire_events()
        self.trajectory: list[list[float]] = [self._row()]
        self.sensors.seed(seed)
        fp = footprint(self.pose, self.joints, self.geometry)
        if check and self.world.contact(fp) is not None:
            raise ValueError("pose: the robot's start footprint overlaps an obstacle or a wall")
        return self.read()

    def _row(self) -> list[float]:
        return [self.t, *self.pose.tolist(), *self.joints.tolist()]

    def read(self) -> SensorReadings:
        dropped = frozenset(
            n for d in self.dropouts if d.t <= self.t < d.t + d.duration for n in d.sensors
        )
        return self.sensors.read(self.world, self.pose, self.joints, dropped)

    @property
    def deformed(self) -> bool:
        return self.forced is not None

    # -- stepping ---------------------------------------------------------------------------
    def _fire_events(self) -> list[EventRecord]:
        fired = []
        while self.pending and self.pending[0].t <= self.t + 1e-9:
            event = self.pending.pop(0)
            if isinstance(event, Deformation):
                target = clamp_joints(np.array(event.joints), self.geometry)
                self.forced = self._deform_towards(target)
                self.joints = self.forced.copy()
                detail: dict[str, object] = {"joints": list(event.joints)}
                if not np.allclose(self.forced, target):
                    detail["held_at"] = [round(float(v), 4) for v in self.forced]
                fired.append(EventRecord(self.t, "deform", detail))
            else:
                self.dropouts.append(event)
                detail = {"sensors": list(event.sensors), "duration": event.duration}
                fired.append(EventRecord(self.t, "dropout", detail))
        return fired

    def _deform_towards(self, target: Array) -> Array:
        """The joints a forced deformation leaves: the body bends towards ``target`` in
        checked steps and no further than it stays clear (what presses it into a shape
        cannot push it through a wall it meets on the way)."""
        start = self.joints.copy()
        travel = float(np.max(np.abs(target - start))) * self.geometry.body_length
        n = max(1, math.ceil(travel / self.check_step))
        reached: Array = start
        for i in range(1, n + 1):
            phi: Array = start + (i / n) * (target - start)
            if self.world.contact(footprint(self.pose, phi, self.geometry)) is not None:
                return reached
            reached = phi
        return target

    def _commanded_joints(self, control: Control, t: float) -> tuple[Array, Array | None]:
        """Joint angles and rates at ``t``: forced by a deformation, else the control's."""
        if self.forced is not None:
            return self.forced, None
        if isinstance(control, FixedShape):
            return control.joints[0], None
        when = np.array([t])
        rates = control.rates(when)[0, 0] if self.joint_mode == "complete" else None
        return control.angles(when)[0, 0], rates

    def step(self, control: Control) -> StepResult:
        """Advance ``dt`` model seconds under ``control`` (a single control, K = 1)."""
        if control.size != 1:
            raise ValueError("control: the stepping simulator takes one control (K = 1)")
        phi, dphi = self._commanded_joints(control, self.t)
        phi = clamp_joints(phi, self.geometry)
        twist = self._twist(control.theta[0], phi, dphi)
        # velocity = (R(ψ)·(vx, vy), ψ̇) and pose + dt·velocity, as rotate() and numpy compute
        # them element by element, on Python floats (a 3-vector is cheaper that way)
        x, y, psi = self.pose.tolist()
        vx, vy, w = twist.tolist()
        c, s = float(np.cos(psi)), float(np.sin(psi))
        dt = self.dt
        target_pose = np.array(
            [x + dt * (c * vx - s * vy), y + dt * (s * vx + c * vy), psi + dt * w]
        )
        if self.forced is None and isinstance(control, FixedShape):
            target_joints = phi  # the same joints at t + dt: clamping again changes nothing
        else:
            target_joints = clamp_joints(
                self._commanded_joints(control, self.t + self.dt)[0], self.geometry
            )
        contact = self._sweep(phi, target_pose, target_joints)
        self.t += self.dt
        records = []
        if contact is not None:
            self.collisions += 1
            detail = {"obstacle": contact.obstacle, "what": contact.what, "part": contact.part}
            records.append(EventRecord(self.t, "collision", detail))
        records += self._fire_events()  # events due by the new clock show in this step's reading
        self.trajectory.append(self._row())
        return StepResult(
            self.t, self.pose.copy(), self.joints.copy(), self.read(), contact, tuple(records)
        )

    def _twist(self, theta: Array, phi: Array, dphi: Array | None) -> Array:
        """``body_twist``, remembered for the screw speeds and shapes met so far (at most
        ``TWISTS_KEPT``): a primitive holds both for many steps, and a plan runs the same
        library primitives again and again (the same inputs give the same twist); new screw
        speeds under a shape met before (steering holds the shape) reuse its solver."""
        if dphi is not None:
            return body_twist(theta, phi, dphi, self.geometry)
        key = theta.tobytes() + phi.tobytes()
        twist = self._twists.get(key)
        if twist is None:
            if len(self._twists) >= TWISTS_KEPT:
                self._twists.clear()
            shape = phi.tobytes()
            solver = self._solvers.get(shape)
            if solver is None:
                if len(self._solvers) >= TWISTS_KEPT:
                    self._solvers.clear()
                solver = self._solvers[shape] = shape_solver(phi, self.geometry)
            twist = self._twists[key] = solver.solve(screw_rhs(theta, self.geometry))
            twist.flags.writeable = False  # shared by every step that meets these inputs
        return twist

    def _body(self, pose: Array, phi: Array) -> Array:
        """The chain (head tip, joint positions) at (pose, phi), the last two answers
        remembered: a step usually starts where the last one ended."""
        key = pose.tobytes() + phi.tobytes()
        for known, value in self._bodies:
            if known == key:
                return value
        value = body_chain(pose, phi, self.geometry)
        self._bodies = [(key, value), *self._bodies[:1]]
        return value

    def _sweep(self, phi0: Array, pose1: Array, phi1: Array) -> Contact | None:
        """Move towards (pose1, phi1) in checked sub-steps; stop before the first contact."""
        pose0 = self.pose
        chain0 = self._body(pose0, phi0)
        chain1 = self._body(pose1, phi1)
        # Chords under-estimate arcs slightly when the body turns; 5 % covers |Δψ| up to ~0.6 rad.
        moved = max(math.sqrt(dx * dx + dy * dy) for dx, dy in (chain1 - chain0).tolist())
        travel = 1.05 * float(moved)
        if self.world.free_within(footprint_of_chain(chain0, self.geometry), travel):
            self.pose, self.joints = pose1, phi1
            return None
        n = max(1, math.ceil(travel / self.check_step))
        for i in range(1, n + 1):
            s = i / n
            pose, phi = pose0 + s * (pose1 - pose0), phi0 + s * (phi1 - phi0)
            contact = self.world.contact(footprint(pose, phi, self.geometry))
            if contact is not None:
                return contact
            self.pose, self.joints = pose, phi
        return None

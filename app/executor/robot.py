"""The Robot port: what the executor may know of a robot (observations) and do (controls).

The executor talks to a robot only through ``Robot``: an ``Observation`` in (model time, the
pose as tracked, range readings with each sensor's pose, range and cone, joint-angle readings,
a contact signal naming the unit and side that touched), a control out for a duration.
``SimRobot`` wraps ``sim.Simulator`` and is the only code of ``app/`` that touches it: the
executor never reads simulator truth (which obstacle a ray hit, whether a deformation was
forced, the true joint angles).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Protocol

from app.missions.spec import MissionSpec
from domain.world import RangeObservation, trusted_observation
from sim.controls import Control
from sim.events import Deformation, Event, SensorDropout
from sim.robot import DEFAULT_GEOMETRY, RobotGeometry, head_tip
from sim.sensors import RangeSensor, SensorReadings, SensorSuite, range_ring
from sim.simulator import Simulator
from sim.world import World

Pose = tuple[float, float, float]
Joints = tuple[float, float, float]


@dataclass(frozen=True)
class ContactReading:
    """A bumper / stall-current signal: which part touched (0 = head, 1..4 = units), which side
    of it (``front``, ``rear``, ``left``, ``right``, in the part's own frame)."""

    part: int
    side: str

    def to_dict(self) -> dict[str, Any]:
        return {"part": self.part, "side": self.side}


@dataclass(frozen=True)
class Observation:
    """Everything the robot reports after a control interval."""

    t: float  # model seconds
    pose: Pose  # tracked point (x, y) and heading ψ, as tracked
    joints: Joints  # joint-angle sensors (NaN while they drop out)
    ranges: tuple[tuple[str, RangeObservation], ...]  # (sensor name, reading with its geometry)
    contact: ContactReading | None = None
    log: tuple[dict[str, Any], ...] = field(default=())  # what the robot itself logs (dropouts)

    def range_of(self, name: str) -> float:
        """The named sensor's distance (NaN if it has no reading or does not exist)."""
        return next((r.distance for n, r in self.ranges if n == name), math.nan)

    def sensors_dict(self) -> dict[str, Any]:
        """Readings as JSON-ready data (for state frames)."""
        ranges = {
            n: None if math.isnan(r.distance) else round(r.distance, 4) for n, r in self.ranges
        }
        joints = [None if math.isnan(v) else round(v, 4) for v in self.joints]
        # Each ray with its geometry, so a viewer draws what the sensor read: a hit ends at the
        # distance, no hit (or a dropout) is a faint ray of the full range.
        rays = [
            {
                "name": n,
                "origin": [round(r.origin[0], 4), round(r.origin[1], 4)],
                "angle": round(r.angle, 4),
                "fov": round(r.fov, 4),
                "max_range": r.max_range,
                "distance": None if math.isnan(r.distance) else round(r.distance, 4),
                "hit": bool(r.hit),
            }
            for n, r in self.ranges
        ]
        return {"ranges": ranges, "joints": joints, "rays": rays}


class Robot(Protocol):
    """A robot as the executor sees it."""

    @property
    def geometry(self) -> RobotGeometry: ...

    def observe(self) -> Observation:
        """The latest observation (no time passes)."""
        ...

    def act(self, control: Control, duration: float) -> Observation:
        """Apply ``control`` for ``duration`` model seconds (the robot stops early when it
        touches something) and report what it observes at the end."""
        ...

    def trajectory(self) -> list[list[float]]:
        """Rows ``[t, x, y, ψ, φ1, φ2, φ3]`` as tracked so far."""
        ...


class SimRobot:
    """The simulated robot behind the Robot port."""

    def __init__(self, simulator: Simulator) -> None:
        self.sim = simulator
        self._contact: ContactReading | None = None
        # Simulator truth for tests and benchmarks (which obstacle each contact touched); the
        # executor never reads it.
        self.truth_contacts: list[tuple[float, int]] = []
        # Like act(): the robot logs its own dropouts; a deformation is for the joint sensors
        # (and the shape guard) to find, not logged twice.
        self._log: list[dict[str, Any]] = [
            {"t": e.t, "kind": e.kind, **e.detail}
            for e in simulator.initial_events
            if e.kind == "dropout"
        ]
        # Each range sensor's fixed part (name, axis offset, fov, range, noise), checked once
        # by building one observation from it: every tick then builds them unchecked.
        self._sensors = [
            (s.name, s.angle, s.fov, s.max_range, s.noise_std)
            for s in simulator.sensors.range_sensors
        ]
        for _, angle, fov, reach, noise in self._sensors:
            RangeObservation((0.0, 0.0), angle, fov, reach, math.nan, False, noise)
        self._last = self._observation(simulator.read())

    @property
    def geometry(self) -> RobotGeometry:
        return self.sim.geometry

    @property
    def contacts(self) -> int:
        """How often the body touched something (the contact sensor's count)."""
        return self.sim.collisions

    def observe(self) -> Observation:
        return self._last

    def act(self, control: Control, duration: float) -> Observation:
        steps = max(1, round(duration / self.sim.dt))
        readings = None
        self._contact = None
        for _ in range(steps):
            result = self.sim.step(control)
            readings = result.readings
            for event in result.events:
                if event.kind == "dropout":  # the robot knows its sensors went quiet
                    self._log.append({"t": event.t, "kind": "dropout", **event.detail})
            if result.contact is not None:
                self._contact = ContactReading(result.contact.part, result.contact.side)
                self.truth_contacts.append((result.t, result.contact.obstacle))
                break  # a bumper stops the motion: the rest of the interval is not driven
        assert readings is not None
        self._last = self._observation(readings)
        return self._last

    def trajectory(self) -> list[list[float]]:
        return self.sim.trajectory

    def _observation(self, readings: SensorReadings) -> Observation:
        pose = readings.pose
        if readings.origin is not None:
            at = readings.origin
        else:
            origin = head_tip(pose, self.sim.geometry)
            at = (float(origin[0]), float(origin[1]))
        forward = float(pose[2]) + math.pi
        if not (math.isfinite(at[0]) and math.isfinite(at[1]) and math.isfinite(forward)):
            raise ValueError("robot pose: must be finite")
        values = readings.ranges
        ranges = []
        for name, angle, fov, reach, noise in self._sensors:
            d = values[name]
            hit = not math.isnan(d) and d < reach
            obs = trusted_observation(at, forward + angle, fov, reach, d, hit, noise)
            ranges.append((name, obs))
        log, self._log = tuple(self._log), []
        x, y, psi = pose.tolist()
        j1, j2, j3 = readings.joints.tolist()
        return Observation(
            t=round(float(self.sim.t), 9),
            pose=(x, y, psi),
            joints=(j1, j2, j3),
            ranges=tuple(ranges),
            contact=self._contact,
            log=log,
        )


__all__ = [
    "DEFAULT_GEOMETRY",
    "ContactReading",
    "Observation",
    "Robot",
    "SimRobot",
    "head_sensors",
    "sim_robot",
]


def head_sensors(spec: MissionSpec) -> tuple[RangeSensor, ...]:
    """The mission's range sensors on the head: the forward IR and the ring, seeded noise."""
    s = spec.sensors
    ring = range_ring(s.ring, s.range, s.noise) if s.ring else ()
    ir = RangeSensor("ir", 0.0, s.ir_range, math.radians(10), 3, s.noise)
    return (ir, *ring)


def sim_robot(spec: MissionSpec, dt: float = 0.25) -> SimRobot:
    """The simulated robot of a mission: its world (every obstacle and map, hidden ones included),
    its sensors (forward IR + ring, seeded noise), deformation and dropout events."""
    obstacles = tuple(spec.world_obstacles())
    events: list[Event] = []
    for e in spec.events:
        if e.type == "deform":
            events.append(Deformation(e.t, e.joints))
        else:
            events.append(SensorDropout(e.t, e.duration, tuple(e.sensors)))
    rasters = tuple(raster for raster, _ in spec.world_maps())  # known and hidden alike
    world = World(spec.bounds.bounds(), obstacles, rasters)
    simulator = Simulator(
        world, sensors=SensorSuite(range_sensors=head_sensors(spec)), events=tuple(events), dt=dt
    )
    simulator.reset(
        (spec.start.x, spec.start.y, spec.start.psi), spec.start_joints(), seed=spec.seed
    )
    return SimRobot(simulator)

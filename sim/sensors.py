"""Sensors: head range sensors by ray casting, joint-angle sensors, pose; seeded noise."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from sim import collision_kernel
from sim.robot import DEFAULT_GEOMETRY, Array, RobotGeometry
from sim.world import World

NOTHING = -2  # what a ray reports when nothing lies within its range


@dataclass(frozen=True)
class RangeSensor:
    """A range sensor on the head, ``angle`` from the robot's forward direction (CCW).

    A field of view wider than 0 is covered by ``rays`` rays; the reading is the nearest hit.
    """

    name: str
    angle: float = 0.0
    max_range: float = 0.8
    fov: float = 0.0
    rays: int = 1
    noise_std: float = 0.0

    def __post_init__(self) -> None:
        for key in ("angle", "max_range", "fov", "noise_std"):
            if not math.isfinite(getattr(self, key)):
                raise ValueError(f"{self.name}.{key}: must be finite")
        if self.max_range <= 0 or self.fov < 0 or self.noise_std < 0 or self.rays < 1:
            raise ValueError(
                f"{self.name}: need max_range > 0, fov >= 0, noise_std >= 0, rays >= 1"
            )

    def ray_angles(self) -> Array:
        if self.rays == 1 or self.fov == 0:
            return np.array([self.angle])
        return self.angle + np.linspace(-self.fov / 2, self.fov / 2, self.rays)


def forward_ir(max_range: float = 0.8, noise_std: float = 0.0) -> tuple[RangeSensor, ...]:
    """The paper's single forward IR sensor (a narrow cone of 10°)."""
    return (RangeSensor("ir", 0.0, max_range, math.radians(10), 3, noise_std),)


def range_ring(
    count: int = 8, max_range: float = 1.5, noise_std: float = 0.0
) -> tuple[RangeSensor, ...]:
    """``count`` evenly spaced sensors around the head, ``ring0`` facing forward."""
    if count < 1:
        raise ValueError("count: need at least one sensor")
    step = 2 * math.pi / count
    return tuple(
        RangeSensor(f"ring{i}", i * step, max_range, 0.0, 1, noise_std) for i in range(count)
    )


@dataclass(frozen=True)
class SensorReadings:
    """One reading of every sensor: ranges by name (``nan`` while dropped out; exactly the
    sensor's ``max_range`` when nothing is within range), joints, pose. ``hits`` names what each
    sensor saw (simulator truth, for tests and logs: a robot port must not pass it on)."""

    ranges: dict[str, float]
    joints: Array
    pose: Array
    hits: dict[str, int] = field(default_factory=dict)
    origin: tuple[float, float] | None = None  # where the rays start (the head tip), if known

    def to_dict(self) -> dict[str, object]:
        return {
            "ranges": {k: (None if math.isnan(v) else round(v, 4)) for k, v in self.ranges.items()},
            "joints": [round(float(v), 4) for v in self.joints],
        }


@dataclass
class SensorSuite:
    """Range sensors on the head plus joint-angle sensors, with one seeded noise stream."""

    range_sensors: tuple[RangeSensor, ...] = field(default_factory=forward_ir)
    joint_noise_std: float = 0.0
    geometry: RobotGeometry = DEFAULT_GEOMETRY
    rng: np.random.Generator = field(default_factory=lambda: np.random.default_rng(0))
    _rays: tuple[tuple[RangeSensor, ...], Array, list[int], float] | None = field(
        default=None, init=False, repr=False, compare=False
    )
    _packed: tuple[Array, NDArray[np.int64], Array, list[tuple[str, float, float]]] = field(
        init=False, repr=False, compare=False
    )

    def __post_init__(self) -> None:
        names = [s.name for s in self.range_sensors]
        if len(set(names)) != len(names):
            raise ValueError("range_sensors: names must be unique")
        if not (math.isfinite(self.joint_noise_std) and self.joint_noise_std >= 0):
            raise ValueError("joint_noise_std: must be finite and >= 0")

    def seed(self, seed: int | None) -> None:
        self.rng = np.random.default_rng(seed)

    def _layout(self) -> tuple[Array, list[int], float]:
        """Every ray's angle from the forward direction, where each sensor's rays start in that
        list, and the longest range: fixed by the sensors, so built once per sensor tuple."""
        cached = self._rays
        if cached is None or cached[0] is not self.range_sensors:
            angles = [s.ray_angles() for s in self.range_sensors]
            offsets = np.cumsum([0, *(a.size for a in angles)]).tolist()
            reach = max((s.max_range for s in self.range_sensors), default=0.0)
            flat = np.concatenate(angles) if angles else np.zeros(0)
            cached = (self.range_sensors, flat, offsets, reach)
            self._rays = cached
            # the same for the compiled read: the offsets with the head's own direction (0)
            # last, where the rays start as an array, and each sensor's range
            self._packed = (
                np.append(flat, 0.0),
                np.array(offsets, dtype=np.int64),
                np.array([s.max_range for s in self.range_sensors], dtype=float),
                [(s.name, s.noise_std, s.max_range) for s in self.range_sensors],
            )
        return cached[1], cached[2], cached[3]

    def read(
        self, world: World, pose: Array, joints: Array, dropped: frozenset[str] = frozenset()
    ) -> SensorReadings:
        forward = float(pose[2]) + math.pi
        ranges: dict[str, float] = {}
        hits: dict[str, int] = {}
        # One ray cast for every ray of every sensor (capped per sensor afterwards); the head
        # tip as head_tip() computes it, its cos and sin in the same numpy call as the rays'.
        offsets, starts, reach = self._layout()
        if collision_kernel.AVAILABLE and self.range_sensors:
            # The same rays, cast and reduced per sensor in one compiled call (forward + 0.0
            # is forward: the head's direction comes out as np.append put it last).
            with_head, first, caps, sensors = self._packed
            angles = forward + with_head
            cos, sin = np.cos(angles), np.sin(angles)
            hl = self.geometry.head_length
            tip = (float(pose[0]) + hl * float(cos[-1]), float(pose[1]) + hl * float(sin[-1]))
            nearest, seen = world.sensor_cast(tip, cos[:-1], sin[:-1], reach, first, caps)
            values, whats = nearest.tolist(), seen.tolist()
            # The noise of every echo in one draw: ``normal(0, σ)`` is ``0 + σ * z`` of the
            # next standard normal, drawn in the same order one by one or all at once.
            noisy = [k for k, s in enumerate(sensors) if s[1] > 0 and whats[k] != NOTHING]
            z = iter(self.rng.standard_normal(len(noisy)).tolist() if noisy else ())
            for k, (name, noise_std, cap) in enumerate(sensors):
                v, what = values[k], whats[k]
                if noise_std > 0 and what != NOTHING:  # as below
                    v = min(max(v + (0.0 + noise_std * next(z)), 0.0), math.nextafter(cap, 0.0))
                ranges[name] = math.nan if name in dropped else v
                hits[name] = what
            return self._finish(ranges, hits, joints, pose, dropped, tip)
        angles = np.append(forward + offsets, forward)
        cos, sin = np.cos(angles), np.sin(angles)
        hl = self.geometry.head_length
        tip = (float(pose[0]) + hl * float(cos[-1]), float(pose[1]) + hl * float(sin[-1]))
        dirs = np.stack([cos[:-1], sin[:-1]], axis=-1)
        all_dist, all_what = world.ray_cast(np.array(tip), dirs, reach)
        dists, whats = all_dist.tolist(), all_what.tolist()  # a few floats: plain Python is faster
        for k, sensor in enumerate(self.range_sensors):
            cap = sensor.max_range
            rays = range(starts[k], starts[k + 1])
            i = min(rays, key=lambda r: min(dists[r], cap))  # the first nearest, as argmin
            value = min(dists[i], cap)
            what = whats[i] if dists[i] <= cap else NOTHING
            if sensor.noise_std > 0 and what != NOTHING:
                # Noise only on real echoes: "nothing within range" reads exactly max_range, so
                # an empty view never invents an obstacle (a noisy echo stays below max_range).
                noisy = value + self.rng.normal(0, sensor.noise_std)
                value = float(np.clip(noisy, 0, np.nextafter(cap, 0)))
            ranges[sensor.name] = math.nan if sensor.name in dropped else value
            hits[sensor.name] = int(what)
        return self._finish(ranges, hits, joints, pose, dropped, tip)

    def _finish(
        self,
        ranges: dict[str, float],
        hits: dict[str, int],
        joints: Array,
        pose: Array,
        dropped: frozenset[str],
        tip: tuple[float, float],
    ) -> SensorReadings:
        """The joint sensors (noise drawn after the ranges' noise) and the readings."""
        measured = np.array(joints, dtype=float)
        if self.joint_noise_std > 0:
            measured = measured + self.rng.normal(0, self.joint_noise_std, size=3)
        if "joints" in dropped:
            measured = np.full(3, np.nan)
        return SensorReadings(ranges, measured, np.array(pose, dtype=float), hits, tip)

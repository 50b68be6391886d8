"""A Gymnasium-style environment around the stepping simulator (gymnasium not required).

Action: 7 numbers, the 4 screw speeds and the 3 joint angles to hold (U2 of the paper).
Observation: ``[x, y, cos ψ, sin ψ, φ1, φ2, φ3 (sensed), goal dx, goal dy, ranges...]``.
Reward: progress towards the goal in metres this step, minus 1 on a collision.
A dropped-out reading is NaN here; ``sim.gym_env`` (the ``gymnasium.Env``) reads it as ``DROPPED``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from sim.controls import FixedShape, as_batch
from sim.events import SensorDropout
from sim.robot import Array
from sim.sensors import SensorReadings
from sim.simulator import Simulator

COLLISION_PENALTY = 1.0
DROPPED = -2.0  # below every reading's range: ranges are >= 0, joint angles >= -π/2


@dataclass
class SnakeEnv:
    """``reset(seed=...)`` then ``step(action)`` → (observation, reward, terminated, truncated, info)."""

    goal: tuple[float, float] = (-2.0, -2.0)
    tolerance: float = 0.05
    max_steps: int = 400
    start: tuple[float, float, float] = (0.0, 0.0, 0.0)
    start_joints: tuple[float, float, float] = (0.0, 0.0, 0.0)
    simulator: Simulator = field(default_factory=Simulator)

    def __post_init__(self) -> None:
        as_batch(self.goal, 2, "goal")
        if not (math.isfinite(self.tolerance) and self.tolerance > 0):
            raise ValueError("tolerance: must be positive and finite")
        if self.max_steps < 1:
            raise ValueError("max_steps: must be at least 1")
        self.steps = 0

    @property
    def action_low(self) -> Array:
        g = self.simulator.geometry
        return np.array([-g.max_screw_speed] * 4 + [-g.max_joint_angle] * 3)

    @property
    def action_high(self) -> Array:
        return -self.action_low

    @property
    def observation_size(self) -> int:
        return 9 + len(self.simulator.sensors.range_sensors)

    def observation_bounds(self) -> tuple[Array, Array]:
        """Lowest and highest value of each observation entry: the tracked point stays inside the
        arena (its walls stop it), joints within ±π/2 (unbounded with joint noise), ranges within
        ``[0, max_range]``; a sensor some dropout names may also read ``DROPPED``."""
        b = self.simulator.world.bounds
        gx, gy = self.goal
        suite = self.simulator.sensors
        dropped = {
            name
            for e in self.simulator.events
            if isinstance(e, SensorDropout)
            for name in e.sensors
        }
        joint = math.inf if suite.joint_noise_std > 0 else self.simulator.geometry.joint_limit
        joint_low = min(-joint, DROPPED) if "joints" in dropped else -joint
        low = [b.xmin, b.ymin, -1.0, -1.0, *[joint_low] * 3, gx - b.xmax, gy - b.ymax]
        high = [b.xmax, b.ymax, 1.0, 1.0, *[joint] * 3, gx - b.xmin, gy - b.ymin]
        for s in suite.range_sensors:
            low.append(DROPPED if s.name in dropped else 0.0)
            high.append(s.max_range)
        return np.array(low, dtype=float), np.array(high, dtype=float)

    def _distance(self) -> float:
        p = self.simulator.pose
        return math.hypot(p[0] - self.goal[0], p[1] - self.goal[1])

    def _observe(self, readings: SensorReadings) -> Array:
        p = readings.pose
        ranges = [readings.ranges[s.name] for s in self.simulator.sensors.range_sensors]
        dx, dy = self.goal[0] - p[0], self.goal[1] - p[1]
        head = [p[0], p[1], math.cos(p[2]), math.sin(p[2])]
        return np.array([*head, *readings.joints, dx, dy, *ranges], dtype=float)

    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Array, dict[str, Any]]:
        options = options or {}
        readings = self.simulator.reset(
            options.get("pose", self.start), options.get("joints", self.start_joints), seed
        )
        self.steps = 0
        return self._observe(readings), {"distance": self._distance(), "t": self.simulator.t}

    def step(self, action: ArrayLike) -> tuple[Array, float, bool, bool, dict[str, Any]]:
        a = as_batch(action, 7, "action")[0]
        a = np.clip(a, self.action_low, self.action_high)
        before = self._distance()
        result = self.simulator.step(FixedShape(a[None, :4], a[None, 4:]))
        self.steps += 1
        after = self._distance()
        reward = before - after - (COLLISION_PENALTY if result.contact else 0.0)
        terminated = after <= self.tolerance or result.contact is not None
        truncated = not terminated and self.steps >= self.max_steps
        info = {
            "distance": after,
            "t": result.t,
            "collision": result.contact.what if result.contact else None,
            "events": [e.kind for e in result.events],
        }
        return self._observe(result.readings), reward, terminated, truncated, info

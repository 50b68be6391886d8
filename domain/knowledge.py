"""What the robot knows now: pose, body shape, remaining goals, known and sensed obstacles."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Literal

from sim.obstacles import Obstacle
from sim.world import Bounds

Order = Literal["given", "any"]


@dataclass(frozen=True)
class Goal:
    x: float
    y: float
    tolerance: float = 0.1
    name: str = ""

    def __post_init__(self) -> None:
        if not (math.isfinite(self.x) and math.isfinite(self.y)):
            raise ValueError("goal: coordinates must be finite")
        if not (math.isfinite(self.tolerance) and self.tolerance > 0):
            raise ValueError("goal.tolerance: must be positive and finite")

    def distance(self, x: float, y: float) -> float:
        return math.hypot(self.x - x, self.y - y)


@dataclass(frozen=True)
class WorldKnowledge:
    """The planner's view of the world; ``sensed`` grows as obstacles are discovered."""

    pose: tuple[float, float, float]
    shape: str
    goals: tuple[Goal, ...]
    order: Order = "given"
    known: tuple[Obstacle, ...] = ()
    sensed: tuple[Obstacle, ...] = ()
    bounds: Bounds = field(default_factory=Bounds)
    joints: tuple[float, float, float] | None = None  # sensed; None: not known (no body check)

    @property
    def obstacles(self) -> tuple[Obstacle, ...]:
        return (*self.known, *self.sensed)

    def with_sensed(self, obstacle: Obstacle) -> WorldKnowledge:
        return replace(self, sensed=(*self.sensed, obstacle))

    def moved(
        self, pose: tuple[float, float, float], joints: tuple[float, float, float] | None = None
    ) -> WorldKnowledge:
        return replace(self, pose=pose, joints=joints if joints is not None else self.joints)

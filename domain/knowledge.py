"""A goal as the domain layer knows it: a point and the tolerance to reach it within."""

from __future__ import annotations

import math
from dataclasses import dataclass


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

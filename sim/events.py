"""Scheduled world events: body deformations and sensor dropouts, in model time."""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Deformation:
    """At model time ``t`` the joints are forced to ``joints`` and held there (paper §6.3)."""

    t: float
    joints: tuple[float, float, float]

    def __post_init__(self) -> None:
        if not (math.isfinite(self.t) and self.t >= 0):
            raise ValueError("deform.t: must be a finite time >= 0")
        if len(self.joints) != 3 or not all(math.isfinite(j) for j in self.joints):
            raise ValueError("deform.joints: need three finite joint angles")
        if any(abs(j) > math.pi / 2 for j in self.joints):
            raise ValueError("deform.joints: joint angles must lie within ±π/2")

    @property
    def kind(self) -> str:
        return "deform"


@dataclass(frozen=True)
class SensorDropout:
    """From ``t`` for ``duration`` model seconds the named sensors read nothing (NaN)."""

    t: float
    duration: float
    sensors: tuple[str, ...]

    def __post_init__(self) -> None:
        if not (math.isfinite(self.t) and self.t >= 0):
            raise ValueError("dropout.t: must be a finite time >= 0")
        if not (math.isfinite(self.duration) and self.duration > 0):
            raise ValueError("dropout.duration: must be positive and finite")
        if not self.sensors:
            raise ValueError("dropout.sensors: name at least one sensor")

    @property
    def kind(self) -> str:
        return "dropout"


Event = Deformation | SensorDropout

"""Range readings in the world frame (``RangeObservation``), built from the head's sensor layout."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from sim.robot import DEFAULT_GEOMETRY, Array, RobotGeometry, head_tip
from sim.sensors import RangeSensor


@dataclass(frozen=True)
class RangeObservation:
    """One range reading in the world frame, with the sensor's geometry."""

    origin: tuple[float, float]  # sensor position, world frame (m)
    angle: float  # cone axis direction, world frame (rad)
    fov: float  # full cone width (rad); 0 = a single ray
    max_range: float  # m
    distance: float  # measured range (m); NaN = no reading (dropout): ignored
    hit: bool  # False: "nothing within max_range" (distance == max_range)
    noise_std: float = 0.0  # the sensor's stated noise (m)

    def __post_init__(self) -> None:
        finite = math.isfinite  # spelled out: a dozen readings per tick build these
        x, y = self.origin
        if not (
            finite(x)
            and finite(y)
            and finite(self.angle)
            and finite(self.fov)
            and finite(self.max_range)
            and finite(self.noise_std)
        ):
            raise ValueError(
                "range observation: origin, angle, fov, max_range, noise must be finite"
            )
        if self.fov < 0 or self.fov >= math.pi or self.max_range <= 0 or self.noise_std < 0:
            raise ValueError("range observation: need 0 <= fov < pi, max_range > 0, noise_std >= 0")
        if not (math.isnan(self.distance) or self.distance >= 0):
            raise ValueError("range observation: distance must be >= 0 or NaN")


def trusted_observation(
    origin: tuple[float, float],
    angle: float,
    fov: float,
    max_range: float,
    distance: float,
    hit: bool,
    noise_std: float,
) -> RangeObservation:
    """A ``RangeObservation`` built without its checks, for a robot port that reads a dozen
    sensors every tick and has checked what they can get wrong already: the sensors' fixed
    fov, range and noise (one checked observation each, once) and a finite pose."""
    obs = object.__new__(RangeObservation)
    fields = obs.__dict__  # a frozen dataclass refuses setattr, not its own dict
    fields["origin"], fields["angle"], fields["fov"] = origin, angle, fov
    fields["max_range"], fields["distance"], fields["hit"] = max_range, distance, hit
    fields["noise_std"] = noise_std
    return obs


def range_observations(
    sensors: Sequence[RangeSensor],
    pose: Sequence[float] | Array,
    ranges: Mapping[str, float],
    geometry: RobotGeometry = DEFAULT_GEOMETRY,
    no_hit_sigmas: float = 2.0,
) -> list[RangeObservation]:
    """The head's range readings (``sim.sensors`` layout) at tracked pose ``[x, y, ψ]`` as
    observations. A missing or NaN reading is a dropout; one within ``no_hit_sigmas`` noise σ of
    ``max_range`` means "nothing within range" (an empty reading is noisy too, then clipped)."""
    p = np.asarray(pose, dtype=float)
    origin = head_tip(p, geometry)
    at = (float(origin[0]), float(origin[1]))
    forward = float(p[2]) + math.pi  # the head leads: the body trails along ψ
    out = []
    for sensor in sensors:
        d = float(ranges.get(sensor.name, math.nan))
        fov = sensor.fov if sensor.rays > 1 else 0.0  # one ray reads along the axis only
        hit = not math.isnan(d) and d < sensor.max_range - no_hit_sigmas * sensor.noise_std
        angle = forward + sensor.angle
        out.append(RangeObservation(at, angle, fov, sensor.max_range, d, hit, sensor.noise_std))
    return out

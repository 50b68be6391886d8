"""A pose task: move a reference point of the body by a start-frame displacement and turn by Δψ.

The lattice primitives (primitives/lattice.py) are learned on it. The reference is the body
centroid (the mean of the four unit centres, ``sim.robot.centroid``) or the tracked point at the
head. The cost of a rollout is the reference point's end-position error in metres plus
``turn_weight`` (m/rad) times the heading error in radians, so one threshold bounds both.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from primitives.params import ParameterSpace
from sim.robot import Array, centroid
from sim.rollout import RolloutConfig, rollout

Reference = Literal["head", "centroid"]
REFERENCES: tuple[Reference, ...] = ("head", "centroid")
LATTICE_DT = 0.05  # model seconds: short primitives need fine Euler steps
TURN_WEIGHT = 1.0  # m/rad: a cost below 3 mm bounds the heading error by 0.17°


@dataclass(frozen=True)
class PoseTask:
    """Carry ``reference`` by ``target[:2]`` (start frame, metres) and turn by ``target[2]``
    (radians) from the start pose (0, 0, 0) within one rollout of ``config``."""

    target: tuple[float, float, float]
    space: ParameterSpace
    reference: Reference = "centroid"
    config: RolloutConfig = field(default=RolloutConfig(10.0, LATTICE_DT))
    turn_weight: float = TURN_WEIGHT

    def __post_init__(self) -> None:
        if len(self.target) != 3 or not all(math.isfinite(v) for v in self.target):
            raise ValueError("target: need three finite values (dx, dy, dpsi)")
        if self.reference not in REFERENCES:
            raise ValueError(f"reference: one of {REFERENCES}, got {self.reference!r}")
        if not (math.isfinite(self.turn_weight) and self.turn_weight >= 0):
            raise ValueError("turn_weight: must be finite and non-negative")

    def end_states(self, params: ArrayLike) -> Array:
        """End states ``[K, 6]`` (tracked point in the start frame) of a batch of parameters."""
        return rollout(self.space.control(params), (0.0, 0.0, 0.0), self.config).end

    def motions(self, params: ArrayLike) -> Array:
        """``[K, 3]``: the reference point's start-frame displacement and the heading change."""
        return reference_motion(self.end_states(params), self.start_joints(params), self.reference)

    def start_joints(self, params: ArrayLike) -> Array:
        control = self.space.control(params)
        out: Array = control.angles(np.zeros(1))[:, 0, :]
        return out

    def errors(self, params: ArrayLike) -> Array:
        """``[K, 2]``: reference position error (m) and absolute heading error (rad)."""
        motion = self.motions(params)
        position = np.linalg.norm(motion[:, :2] - np.asarray(self.target[:2]), axis=-1)
        turn = np.abs(wrap(motion[:, 2] - self.target[2]))
        return np.stack([position, turn], axis=-1)

    def costs(self, params: ArrayLike) -> Array:
        """Position error + ``turn_weight`` × heading error, ``[K]``."""
        err = self.errors(params)
        out: Array = err[:, 0] + self.turn_weight * err[:, 1]
        return out


def wrap(angle: Array) -> Array:
    """Angles wrapped to [−π, π)."""
    out: Array = (np.asarray(angle) + math.pi) % (2 * math.pi) - math.pi
    return out


def reference_motion(end: Array, start_joints: Array, reference: Reference) -> Array:
    """Start-frame displacement of ``reference`` and Δψ, ``[K, 3]``, from end states ``[K, 6]``
    of rollouts that began at the pose (0, 0, 0) with joints ``start_joints`` ``[K, 3]``."""
    if reference == "head":
        return np.array(end[:, :3])
    start = centroid(np.zeros((len(end), 3)), start_joints)
    moved = centroid(end[:, :3], end[:, 3:6]) - start
    return np.concatenate([moved, end[:, 2:3]], axis=-1)

"""The paper's parameter vectors U1, U2, U3 (eqs. 4, 5, 12) and how each becomes a control."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from primitives.shapes import shape_named
from sim.controls import Control, FixedShape, PeriodicGait
from sim.robot import Array

Kind = Literal["U1", "U2", "U3"]
KINDS: tuple[Kind, ...] = ("U1", "U2", "U3")
SPEED_CLAMP = 1.0  # rad/s, paper §3.3
JOINT_CLAMP = 1.0  # rad, paper §3.3


@dataclass(frozen=True)
class ParameterSpace:
    """U1 = 4 screw speeds with ``joints`` held; U2 = 4 speeds + 3 joint angles;
    U3 = 4 speeds + 3 joint phases of the periodic gait."""

    kind: Kind
    joints: tuple[float, float, float] = (0.0, 0.0, 0.0)  # the held shape for U1
    speed_limit: float = SPEED_CLAMP  # |θ̇| clamp; lattice primitives refine under a lower cap

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"kind: one of {KINDS}, got {self.kind!r}")
        if not 0 < self.speed_limit <= SPEED_CLAMP:
            raise ValueError(f"speed_limit: in (0, {SPEED_CLAMP}] rad/s")

    @property
    def size(self) -> int:
        return 4 if self.kind == "U1" else 7

    def clamp(self, params: Array) -> Array:
        """The paper's clamps: |θ̇| <= 1 rad/s (``speed_limit``), |φ| <= 1 rad; phases are free."""
        out = np.array(params, dtype=float)
        out[..., :4] = np.clip(out[..., :4], -self.speed_limit, self.speed_limit)
        if self.kind == "U2":
            out[..., 4:] = np.clip(out[..., 4:], -JOINT_CLAMP, JOINT_CLAMP)
        return out

    def bounds(self) -> tuple[Array, Array]:
        hi = np.full(self.size, self.speed_limit)
        if self.kind == "U2":
            hi[4:] = JOINT_CLAMP
        elif self.kind == "U3":
            hi[4:] = np.pi
        return -hi, hi

    def control(self, params: ArrayLike) -> Control:
        p = np.atleast_2d(np.asarray(params, dtype=float))
        if p.shape[-1] != self.size:
            raise ValueError(
                f"params: expected {self.size} values for {self.kind}, got {p.shape[-1]}"
            )
        if self.kind == "U1":
            return FixedShape.of(p, np.broadcast_to(self.joints, (p.shape[0], 3)))
        if self.kind == "U2":
            return FixedShape.of(p[:, :4], p[:, 4:])
        return PeriodicGait.of(p[:, :4], p[:, 4:])

    @classmethod
    def for_shape(cls, shape: str) -> ParameterSpace:
        """U3 for the periodic gait, U1 holding a fixed shape, U2 for ``free`` (joints learned)."""
        if shape == "free":
            return cls("U2")
        s = shape_named(shape)
        return cls("U3") if s.periodic else cls("U1", s.joints)

    def split(
        self, params: ArrayLike
    ) -> tuple[list[float], list[float] | None, list[float] | None]:
        """(theta, joints, phases) of one parameter vector, as stored in the library."""
        p = [float(v) for v in np.asarray(params, dtype=float)]
        if self.kind == "U1":
            return p, list(self.joints), None
        if self.kind == "U2":
            return p[:4], p[4:], None
        return p[:4], None, p[4:]

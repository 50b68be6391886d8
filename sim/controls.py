"""Control inputs: screw speeds with a fixed body shape or a periodic gait, validated.

A control is batched: ``theta`` is ``[K, 4]`` and the joint part ``[K, 3]``; a single control
is the case K = 1. ``angles(t)`` and ``rates(t)`` give the joint angles and joint rates at
model times ``t`` (``[N]``) as ``[K, N, 3]``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from sim.robot import DEFAULT_GEOMETRY, N_JOINTS, N_UNITS, Array, RobotGeometry

GAIT_AMPLITUDE = 0.2  # rad, paper eq. 13
GAIT_OMEGA = 0.6  # rad per model second
GAIT_CYCLE = 2 * math.pi / GAIT_OMEGA  # model seconds of one cycle of the paper's gait (10.47)


def as_batch(value: ArrayLike, width: int, name: str) -> Array:
    """``value`` as a finite float array ``[K, width]`` (a single vector becomes K = 1)."""
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: expected numbers, got {value!r}") from exc
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != width or arr.shape[0] == 0:
        raise ValueError(f"{name}: expected shape [{width}] or [K, {width}], got {list(arr.shape)}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: values must be finite (no NaN or inf)")
    return arr


def _single(value: ArrayLike, width: int) -> list[float] | None:
    """``value`` as ``width`` finite floats when it is one plain vector of them (a float array
    ``[width]``, or a list or tuple of floats), else ``None`` (``as_batch`` decides)."""
    if type(value) is np.ndarray:
        if value.shape != (width,) or value.dtype.char != "d":
            return None
        out: list[float] = value.tolist()
    elif isinstance(value, list | tuple) and len(value) == width:
        if not all(type(v) is float for v in value):
            return None
        out = list(value)
    else:
        return None
    # a NaN or an infinity makes the sum one (finite values may overflow it: then the
    # batched path decides, as it does for anything else)
    return out if math.isfinite(sum(out)) else None


def check_screw_speeds(theta: Array, geometry: RobotGeometry, name: str = "theta") -> None:
    limit = geometry.max_screw_speed
    if np.any(np.abs(theta) > limit + 1e-12):
        raise ValueError(f"{name}: screw speeds must lie within ±{limit} rad/s")


def check_joint_angles(phi: Array, geometry: RobotGeometry, name: str = "joints") -> None:
    limit = geometry.joint_limit
    if np.any(np.abs(phi) > limit + 1e-12):
        raise ValueError(f"{name}: joint angles must lie within ±π/2 ({limit:.4f} rad)")


def clamp_joints(phi: Array, geometry: RobotGeometry) -> Array:
    """Keep joints off the singular all-parallel shapes at exactly ±π/2 (docs/robot-model.md, "Solving")."""
    m = geometry.max_joint_angle
    # np.clip's own numbers (the larger of phi and -m, then the smaller of that and m)
    # without its Python-level checks: the simulator clamps three angles every step
    out: Array = np.minimum(np.maximum(phi, -m), m)
    return out


@dataclass(frozen=True)
class FixedShape:
    """Screw speeds ``[K, 4]`` with joints held at ``[K, 3]`` (parameter vectors U1 and U2)."""

    theta: Array
    joints: Array

    @classmethod
    def of(
        cls, theta: ArrayLike, joints: ArrayLike, geometry: RobotGeometry = DEFAULT_GEOMETRY
    ) -> FixedShape:
        speeds, angles = _single(theta, N_UNITS), _single(joints, N_JOINTS)
        if speeds is not None and angles is not None:
            # One control, as the executor builds every tick: the checks and the clamp on
            # Python floats (the same comparisons and the same min/max as np.clip); anything
            # out of range takes the batched path below for its error.
            speed_limit = geometry.max_screw_speed + 1e-12
            angle_limit = geometry.joint_limit + 1e-12
            if all(abs(v) <= speed_limit for v in speeds) and all(
                abs(v) <= angle_limit for v in angles
            ):
                m = geometry.max_joint_angle
                return cls(np.array([speeds]), np.array([[min(max(v, -m), m) for v in angles]]))
        th = as_batch(theta, N_UNITS, "theta")
        ph = as_batch(joints, N_JOINTS, "joints")
        if ph.shape[0] == 1 and th.shape[0] > 1:
            ph = np.repeat(ph, th.shape[0], axis=0)
        if ph.shape[0] != th.shape[0]:
            raise ValueError(f"joints: batch size {ph.shape[0]} != theta's {th.shape[0]}")
        check_screw_speeds(th, geometry)
        check_joint_angles(ph, geometry)
        return cls(th, clamp_joints(ph, geometry))

    @property
    def size(self) -> int:
        return int(self.theta.shape[0])

    def angles(self, t: Array) -> Array:
        return np.broadcast_to(self.joints[:, None, :], (self.size, t.size, N_JOINTS))

    def rates(self, t: Array) -> Array:
        return np.zeros((self.size, t.size, N_JOINTS))


@dataclass(frozen=True)
class PeriodicGait:
    """Screw speeds ``[K, 4]`` and joint phases ``[K, 3]``: φ_i(t) = A sin(ω (t − t0) + ϕ_i) (U3).

    With a finite ``t_end`` the gait stops there and the joints hold φ(t_end): a motion of
    whole gait cycles (t_end − t0 a multiple of 2π/ω) ends in its start shape even when its
    duration is rounded up to whole control ticks, so the next one starts without a jump."""

    theta: Array
    phases: Array
    amplitude: float = GAIT_AMPLITUDE
    omega: float = GAIT_OMEGA
    t0: float = 0.0
    t_end: float = math.inf

    @classmethod
    def of(
        cls,
        theta: ArrayLike,
        phases: ArrayLike,
        amplitude: float = GAIT_AMPLITUDE,
        omega: float = GAIT_OMEGA,
        t0: float = 0.0,
        geometry: RobotGeometry = DEFAULT_GEOMETRY,
        t_end: float = math.inf,
    ) -> PeriodicGait:
        th = as_batch(theta, N_UNITS, "theta")
        ph = as_batch(phases, N_JOINTS, "phases")
        if ph.shape[0] == 1 and th.shape[0] > 1:
            ph = np.repeat(ph, th.shape[0], axis=0)
        if ph.shape[0] != th.shape[0]:
            raise ValueError(f"phases: batch size {ph.shape[0]} != theta's {th.shape[0]}")
        for name, value in (("amplitude", amplitude), ("omega", omega), ("t0", t0)):
            if not math.isfinite(value):
                raise ValueError(f"{name}: must be finite")
        if not 0.0 <= amplitude <= geometry.max_joint_angle:
            raise ValueError(f"amplitude: must lie within [0, {geometry.max_joint_angle:.4f}]")
        if math.isnan(t_end) or t_end < t0:
            raise ValueError("t_end: must be at least t0 (or infinite: the gait never stops)")
        check_screw_speeds(th, geometry)
        return cls(th, ph, float(amplitude), float(omega), float(t0), float(t_end))

    @property
    def size(self) -> int:
        return int(self.theta.shape[0])

    def _arg(self, t: Array) -> Array:
        held = np.minimum(t, self.t_end)
        return self.omega * (held[None, :, None] - self.t0) + self.phases[:, None, :]

    def angles(self, t: Array) -> Array:
        return self.amplitude * np.sin(self._arg(t))

    def rates(self, t: Array) -> Array:
        moving = (np.asarray(t) < self.t_end)[None, :, None]  # held joints do not move
        return np.where(moving, self.amplitude * self.omega * np.cos(self._arg(t)), 0.0)


Control = FixedShape | PeriodicGait


def take(control: Control, index: int) -> Control:
    """The single control (K = 1) at ``index`` of a batch."""
    sl = slice(index, index + 1)
    if isinstance(control, FixedShape):
        return FixedShape(control.theta[sl], control.joints[sl])
    return PeriodicGait(
        control.theta[sl],
        control.phases[sl],
        control.amplitude,
        control.omega,
        control.t0,
        control.t_end,
    )

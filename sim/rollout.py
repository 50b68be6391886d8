"""Batched open-loop rollouts: K controls simulated at once, without a Python loop.

Explicit Euler on (x, y, ψ) exactly as docs/robot-model.md ("Time"). Two kernels compute the same thing:

- ``numba`` (``sim/kernels.py``): one compiled loop per rollout, ~5× the numpy path at K = 40
  (~350× the scalar reference, ``bench/sim.py``); the default whenever numba is importable.
- ``numpy``: the body-frame twist depends only on the shape (and joint rates), never on the
  pose, so all twists of all steps are solved in one stacked least-squares call; ψ and (x, y)
  are then running sums. For a fixed shape the twist is solved once per rollout.

The setting ``SCREWSNAKE_KERNELS`` (``auto``, ``numba`` or ``numpy``; default ``auto``: numba
when importable, else numpy) chooses; ``rollout(..., kernel=...)`` overrides it per call.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import ModuleType
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from sim.controls import Control, FixedShape, as_batch
from sim.kernel_setting import KERNELS, Kernel, kernel_setting
from sim.robot import DEFAULT_GEOMETRY, Array, RobotGeometry, body_twist, rotate

JointMode = Literal["paper", "complete"]
JOINT_MODES: tuple[JointMode, ...] = ("paper", "complete")
MAX_STEPS = 1_000_000


@dataclass(frozen=True)
class RolloutConfig:
    """Horizon and integration: the paper's rollout is 100 model seconds at dt = 1."""

    duration: float = 100.0
    dt: float = 1.0
    joint_mode: JointMode = "paper"

    def __post_init__(self) -> None:
        if not (math.isfinite(self.duration) and self.duration > 0):
            raise ValueError("duration: must be a positive finite number of model seconds")
        if not (math.isfinite(self.dt) and 0 < self.dt <= self.duration):
            raise ValueError("dt: must be positive, finite and at most the duration")
        if self.joint_mode not in JOINT_MODES:
            raise ValueError(f"joint_mode: must be one of {JOINT_MODES}, got {self.joint_mode!r}")
        if self.steps > MAX_STEPS:
            raise ValueError(f"dt: duration/dt gives more than {MAX_STEPS} steps")

    @property
    def steps(self) -> int:
        return max(1, round(self.duration / self.dt))

    def times(self) -> Array:
        return np.arange(self.steps + 1, dtype=float) * self.dt


PAPER_ROLLOUT = RolloutConfig()


@dataclass(frozen=True)
class Rollouts:
    """States ``[K, N+1, 6]`` (x, y, ψ, φ1, φ2, φ3) at ``times`` ``[N+1]``."""

    times: Array
    states: Array

    @property
    def end(self) -> Array:
        """Final states ``[K, 6]``."""
        return self.states[:, -1, :]


def start_poses(start: ArrayLike, size: int) -> Array:
    """Start poses ``[K, 3]`` from one pose ``[3]`` or one per rollout."""
    poses = as_batch(start, 3, "start")
    if poses.shape[0] == 1:
        poses = np.repeat(poses, size, axis=0)
    if poses.shape[0] != size:
        raise ValueError(f"start: {poses.shape[0]} poses for {size} rollouts")
    return poses


def twists(
    control: Control,
    times: Array,
    config: RolloutConfig,
    geometry: RobotGeometry,
    phi: Array | None = None,
) -> Array:
    """Body-frame twists ``[K, N, 3]`` at the step times ``times`` ``[N]`` (``phi``: their joint
    angles, when the caller has them already)."""
    if isinstance(control, FixedShape):
        # Constant shape, no joint motion: one solve per rollout serves every step.
        once = body_twist(control.theta, control.joints, None, geometry)
        return np.broadcast_to(once[:, None, :], (control.size, times.size, 3))
    phi = control.angles(times) if phi is None else phi
    dphi = control.rates(times) if config.joint_mode == "complete" else None
    theta = np.broadcast_to(control.theta[:, None, :], (*phi.shape[:2], 4))
    return body_twist(theta, phi, dphi, geometry)


def compiled_kernels(kernel: Kernel | None = None) -> ModuleType | None:
    """``sim.kernels`` when ``kernel`` (default: the setting) selects it, else ``None``.

    ``auto`` takes numba when it imports and numpy otherwise; ``numba`` insists (ImportError)."""
    choice = kernel_setting() if kernel is None else kernel
    if choice not in KERNELS:
        raise ValueError(f"kernel: must be one of {KERNELS}, got {choice!r}")
    if choice == "numpy":
        return None
    try:
        from sim import kernels
    except ImportError:
        if choice == "numba":
            raise
        return None
    return kernels


def rollout(
    control: Control,
    start: ArrayLike = (0.0, 0.0, 0.0),
    config: RolloutConfig = PAPER_ROLLOUT,
    geometry: RobotGeometry = DEFAULT_GEOMETRY,
    kernel: Kernel | None = None,
) -> Rollouts:
    """Simulate every control of the batch from ``start`` for ``config.duration``.

    ``kernel`` picks the implementation (default: the ``SCREWSNAKE_KERNELS`` setting); both
    give the same states to rounding."""
    times = config.times()
    poses0 = start_poses(start, control.size)
    compiled = compiled_kernels(kernel)
    if compiled is not None:
        return Rollouts(times, _compiled_states(compiled, control, poses0, config, geometry))
    phi = control.angles(times)
    tw = twists(control, times[:-1], config, geometry, phi[:, :-1])  # twist held over [t_k, t_k+1)
    dpsi = config.dt * tw[..., 2]
    psi = poses0[:, 2:3] + np.concatenate([np.zeros((control.size, 1)), np.cumsum(dpsi, 1)], 1)
    dxy = config.dt * rotate(tw[..., :2], psi[:, :-1])
    zero = np.zeros((control.size, 1, 2))
    xy = poses0[:, None, :2] + np.concatenate([zero, np.cumsum(dxy, axis=1)], axis=1)
    states = np.concatenate([xy, psi[..., None], phi], axis=-1)
    return Rollouts(times, states)


def _compiled_states(
    kernels: ModuleType,
    control: Control,
    poses0: Array,
    config: RolloutConfig,
    geometry: RobotGeometry,
) -> Array:
    """States ``[K, N+1, 6]`` from the compiled kernels (float64, C-contiguous inputs only, so
    each kernel is compiled for one signature)."""
    states = np.empty((control.size, config.steps + 1, 6))
    geo = kernels.geometry_vector(geometry)
    theta = np.ascontiguousarray(control.theta, dtype=float)
    start = np.ascontiguousarray(poses0, dtype=float)
    if isinstance(control, FixedShape):
        joints = np.ascontiguousarray(control.joints, dtype=float)
        kernels.fixed_shape_rollouts(theta, joints, start, float(config.dt), geo, states)
    else:
        phases = np.ascontiguousarray(control.phases, dtype=float)
        kernels.periodic_gait_rollouts(
            theta,
            phases,
            float(control.amplitude),
            float(control.omega),
            float(control.t0),
            float(control.t_end),
            config.joint_mode == "complete",
            start,
            float(config.dt),
            geo,
            states,
        )
    return states


def end_states(
    control: Control,
    start: ArrayLike = (0.0, 0.0, 0.0),
    config: RolloutConfig = PAPER_ROLLOUT,
    geometry: RobotGeometry = DEFAULT_GEOMETRY,
    kernel: Kernel | None = None,
) -> Array:
    """Final states ``[K, 6]`` of a batch (what learners need for their costs)."""
    return rollout(control, start, config, geometry, kernel).end

"""Scalar reference model: the model of docs/robot-model.md line by line, one rollout at a time.

This is the oracle the batched simulator is checked against (tests) and measured against
(``bench/sim.py``). It solves the world-frame constraints with ``np.linalg.lstsq`` each step.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from sim.robot import DEFAULT_GEOMETRY, Array, RobotGeometry

JointFunction = Callable[[float], Array]


def world_constraint_matrices(
    psi: float, phi: Sequence[float] | Array, geometry: RobotGeometry = DEFAULT_GEOMETRY
) -> tuple[Array, Array]:
    """World-frame ``A_b`` and ``A_j`` (4×3 each) built row by row as in docs/robot-model.md ("Motion")."""
    th = [psi, psi + phi[0], psi + phi[0] + phi[1], psi + phi[0] + phi[1] + phi[2]]
    seg = geometry.segments
    alpha = geometry.alpha
    ab, aj = np.zeros((4, 3)), np.zeros((4, 3))
    for i in range(4):
        a = alpha[i] + th[i]

        def arm(j0: int, i: int = i, a: float = a) -> float:
            return float(
                geometry.front_length * math.sin(alpha[i])
                + sum(seg[j] * math.sin(a - th[j]) for j in range(j0, i))
            )

        ab[i] = math.cos(a), math.sin(a), arm(0)
        for k in range(i):
            aj[i, k] = arm(k + 1)
    return ab, aj


def reference_rollout(
    theta: Sequence[float],
    phi_of_t: JointFunction,
    dphi_of_t: JointFunction | None = None,
    start: Sequence[float] = (0.0, 0.0, 0.0),
    duration: float = 100.0,
    dt: float = 1.0,
    geometry: RobotGeometry = DEFAULT_GEOMETRY,
) -> Array:
    """States ``[N+1, 6]`` of one rollout; ``dphi_of_t`` switches on the complete joint mode."""
    steps = max(1, round(duration / dt))
    u = np.asarray(theta, dtype=float)
    w = np.zeros(6)
    w[:3] = start
    out = np.zeros((steps + 1, 6))
    for k in range(steps):
        t = k * dt
        w[3:6] = phi_of_t(t)
        out[k] = w
        ab, aj = world_constraint_matrices(w[2], w[3:6], geometry)
        rhs = -geometry.screw_radius * np.sin(geometry.alpha) * u
        if dphi_of_t is not None:
            rhs = rhs - aj @ dphi_of_t(t)
        w[:3] += dt * np.linalg.lstsq(ab, rhs, rcond=geometry.rcond)[0]
    w[3:6] = phi_of_t(steps * dt)
    out[steps] = w
    return out

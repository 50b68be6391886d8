"""Compiled rollout kernels (numba): each rollout is one loop over its steps, on scalars.

The same model as the numpy path of ``sim/rollout.py`` (docs/robot-model.md), written for a
compiler instead of for whole-array operations: the numpy path pays for ~100 array operations
and their temporaries, this for ~8 trig calls per step (~90 ns). Trig is saved by angle addition:
the unit headings' cosines and sines are products of the joints' ones, and a gait's
``sin(ω t + ϕ)`` is ``sin ωt cos ϕ + cos ωt sin ϕ`` with ``ωt`` shared by the whole batch.

Importing this module imports numba (an ``ImportError`` when it is missing: ``sim.rollout``
then falls back to numpy). ``cache=True`` keeps the machine code on disk (``__pycache__``
beside this file, else numba's per-user cache), so only the first process ever compiles.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import lru_cache
from typing import Any, TypeVar, cast

import numba
import numpy as np

from sim.robot import WELL_CONDITIONED, Array, RobotGeometry

F = TypeVar("F", bound=Callable[..., Any])


def _compiled(fn: F) -> F:
    """``numba.njit`` with the on-disk cache, typed for mypy as the function it wraps."""
    return cast(F, numba.njit(cache=True, nogil=True)(fn))


# Layout of the geometry vector the kernels take (one float array: cheap to pass, no classes).
_COS_ALPHA, _SIN_ALPHA, _SEG, _L1, _R, _RCOND, _WELL = 0, 4, 8, 11, 12, 13, 14
_GEOMETRY_SIZE = 15


@lru_cache(maxsize=16)
def geometry_vector(geometry: RobotGeometry) -> Array:
    """The constants of ``geometry`` the kernels read, as one float array."""
    out = np.empty(_GEOMETRY_SIZE)
    out[_COS_ALPHA : _COS_ALPHA + 4] = np.cos(geometry.alpha)
    out[_SIN_ALPHA : _SIN_ALPHA + 4] = np.sin(geometry.alpha)
    out[_SEG : _SEG + 3] = geometry.segments
    out[_L1] = geometry.front_length
    out[_R] = geometry.screw_radius
    out[_RCOND] = geometry.rcond
    out[_WELL] = WELL_CONDITIONED
    out.flags.writeable = False  # shared by every caller through the cache
    return out


@_compiled
def lstsq_svd(a: Array, b: Array, rcond: float) -> tuple[float, float, float]:
    """Minimum-norm least squares of one 4×3 system through the SVD, as ``np.linalg.pinv``:
    singular values at or below ``rcond`` times the largest count as zero."""
    u, s, vt = np.linalg.svd(a, full_matrices=False)
    cutoff = rcond * s[0]
    x = np.zeros(3)
    for q in range(3):
        if s[q] > cutoff:
            coef = (u[0, q] * b[0] + u[1, q] * b[1] + u[2, q] * b[2] + u[3, q] * b[3]) / s[q]
            for p in range(3):
                x[p] += coef * vt[q, p]
    return x[0], x[1], x[2]


@_compiled
def lstsq_rows(a: Array, b: Array, rcond: float, well: float) -> tuple[float, float, float]:
    """``sim.robot.least_squares`` for one 4×3 system ``a`` ``[4, 3]``, ``b`` ``[4]`` (tests)."""
    return lstsq4(
        a[0, 0], a[1, 0], a[2, 0], a[3, 0],
        a[0, 1], a[1, 1], a[2, 1], a[3, 1],
        a[0, 2], a[1, 2], a[2, 2], a[3, 2],
        b[0], b[1], b[2], b[3], rcond, well,
    )  # fmt: skip


@_compiled
def lstsq4(
    a0: float, a1: float, a2: float, a3: float,
    b0: float, b1: float, b2: float, b3: float,
    c0: float, c1: float, c2: float, c3: float,
    r0: float, r1: float, r2: float, r3: float,
    rcond: float, well: float,
) -> tuple[float, float, float]:  # fmt: skip
    """``sim.robot.least_squares`` for one system with columns ``a``, ``b``, ``c`` and right-hand
    side ``r`` (scalars, so the compiler keeps them in registers): the normal equations with the
    closed-form 3×3 inverse, the SVD below the same condition threshold."""
    m00 = a0 * a0 + a1 * a1 + a2 * a2 + a3 * a3
    m11 = b0 * b0 + b1 * b1 + b2 * b2 + b3 * b3
    m22 = c0 * c0 + c1 * c1 + c2 * c2 + c3 * c3
    m01 = a0 * b0 + a1 * b1 + a2 * b2 + a3 * b3
    m02 = a0 * c0 + a1 * c1 + a2 * c2 + a3 * c3
    m12 = b0 * c0 + b1 * c1 + b2 * c2 + b3 * c3
    q0 = a0 * r0 + a1 * r1 + a2 * r2 + a3 * r3
    q1 = b0 * r0 + b1 * r1 + b2 * r2 + b3 * r3
    q2 = c0 * r0 + c1 * r1 + c2 * r2 + c3 * r3
    i00, i11, i22 = m11 * m22 - m12 * m12, m00 * m22 - m02 * m02, m00 * m11 - m01 * m01
    i01, i02, i12 = m02 * m12 - m01 * m22, m01 * m12 - m02 * m11, m01 * m02 - m00 * m12
    det = m00 * i00 + m01 * i01 + m02 * i02
    scale = (m00 + m11 + m22) / 3.0
    if det > well * scale**3:
        inv = 1.0 / det
        return (
            (i00 * q0 + i01 * q1 + i02 * q2) * inv,
            (i01 * q0 + i11 * q1 + i12 * q2) * inv,
            (i02 * q0 + i12 * q1 + i22 * q2) * inv,
        )
    a = np.empty((4, 3))
    a[0, 0], a[1, 0], a[2, 0], a[3, 0] = a0, a1, a2, a3
    a[0, 1], a[1, 1], a[2, 1], a[3, 1] = b0, b1, b2, b3
    a[0, 2], a[1, 2], a[2, 2], a[3, 2] = c0, c1, c2, c3
    return lstsq_svd(a, np.array([r0, r1, r2, r3]), rcond)


@_compiled
def shape_twist(
    cos_phi: Array, sin_phi: Array, theta: Array, dphi: Array, geo: Array
) -> tuple[float, float, float]:
    """Body-frame twist ``(vx, vy, ψ̇)`` of one shape (docs/robot-model.md, "Motion"): joints given by their
    cosines and sines ``[3]``, screw speeds ``[4]``, joint rates ``[3]`` (zeros: paper mode)."""
    # e^{iθ_i} of the unit headings θ_0 = 0, θ_i = φ_0 + ... + φ_{i-1}: products, no trig.
    hc1, hs1 = cos_phi[0], sin_phi[0]
    hc2 = hc1 * cos_phi[1] - hs1 * sin_phi[1]
    hs2 = hs1 * cos_phi[1] + hc1 * sin_phi[1]
    hc3 = hc2 * cos_phi[2] - hs2 * sin_phi[2]
    hs3 = hs2 * cos_phi[2] + hc2 * sin_phi[2]
    # cos and sin of a_i = α_i + θ_i, the axle directions (θ_0 = 0).
    ca0, sa0 = geo[_COS_ALPHA], geo[_SIN_ALPHA]
    ca1 = geo[_COS_ALPHA + 1] * hc1 - geo[_SIN_ALPHA + 1] * hs1
    sa1 = geo[_SIN_ALPHA + 1] * hc1 + geo[_COS_ALPHA + 1] * hs1
    ca2 = geo[_COS_ALPHA + 2] * hc2 - geo[_SIN_ALPHA + 2] * hs2
    sa2 = geo[_SIN_ALPHA + 2] * hc2 + geo[_COS_ALPHA + 2] * hs2
    ca3 = geo[_COS_ALPHA + 3] * hc3 - geo[_SIN_ALPHA + 3] * hs3
    sa3 = geo[_SIN_ALPHA + 3] * hc3 + geo[_COS_ALPHA + 3] * hs3
    # S_ij = s_j sin(a_i − θ_j), the six pairs j < i.
    seg0, seg1, seg2 = geo[_SEG], geo[_SEG + 1], geo[_SEG + 2]
    s10, s20, s30 = seg0 * sa1, seg0 * sa2, seg0 * sa3
    s21 = seg1 * (sa2 * hc1 - ca2 * hs1)
    s31 = seg1 * (sa3 * hc1 - ca3 * hs1)
    s32 = seg2 * (sa3 * hc2 - ca3 * hs2)
    l1, r = geo[_L1], geo[_R]
    l1s0, l1s1 = l1 * geo[_SIN_ALPHA], l1 * geo[_SIN_ALPHA + 1]
    l1s2, l1s3 = l1 * geo[_SIN_ALPHA + 2], l1 * geo[_SIN_ALPHA + 3]
    # Right-hand side: screw drive minus the joint-rate columns c_ik = l1 sin α_i + Σ_{k<j<i} S_ij.
    d0, d1, d2 = dphi[0], dphi[1], dphi[2]
    b0 = -r * geo[_SIN_ALPHA] * theta[0]
    b1 = -r * geo[_SIN_ALPHA + 1] * theta[1] - l1s1 * d0
    b2 = -r * geo[_SIN_ALPHA + 2] * theta[2] - ((l1s2 + s21) * d0 + l1s2 * d1)
    b3 = -r * geo[_SIN_ALPHA + 3] * theta[3] - (
        (l1s3 + s31 + s32) * d0 + (l1s3 + s32) * d1 + l1s3 * d2
    )
    return lstsq4(
        ca0, ca1, ca2, ca3,
        sa0, sa1, sa2, sa3,
        l1s0, l1s1 + s10, l1s2 + s20 + s21, l1s3 + s30 + s31 + s32,
        b0, b1, b2, b3,
        geo[_RCOND], geo[_WELL],
    )  # fmt: skip


@_compiled
def fixed_shape_rollouts(
    theta: Array, joints: Array, start: Array, dt: float, geo: Array, states: Array
) -> None:
    """Fill ``states`` ``[K, N+1, 6]`` for screw speeds ``[K, 4]`` at fixed joints ``[K, 3]``:
    one twist per rollout, then explicit Euler on the pose."""
    cos_phi, sin_phi, dphi = np.empty(3), np.empty(3), np.zeros(3)
    for k in range(theta.shape[0]):
        for j in range(3):
            cos_phi[j], sin_phi[j] = math.cos(joints[k, j]), math.sin(joints[k, j])
        vx, vy, w = shape_twist(cos_phi, sin_phi, theta[k], dphi, geo)
        x, y, psi = start[k, 0], start[k, 1], start[k, 2]
        for n in range(states.shape[1]):
            row = states[k, n]
            row[0], row[1], row[2] = x, y, psi
            row[3], row[4], row[5] = joints[k, 0], joints[k, 1], joints[k, 2]
            c, s = math.cos(psi), math.sin(psi)
            x += dt * (c * vx - s * vy)
            y += dt * (s * vx + c * vy)
            psi += dt * w


@_compiled
def periodic_gait_rollouts(
    theta: Array,
    phases: Array,
    amplitude: float,
    omega: float,
    t0: float,
    t_end: float,
    complete: bool,
    start: Array,
    dt: float,
    geo: Array,
    states: Array,
) -> None:
    """Fill ``states`` ``[K, N+1, 6]`` for gaits φ_j(t) = A sin(ω (min(t, t_end) − t0) + ϕ_j):
    the twist of the shape at t_n (and its joint rates in ``complete`` mode) held over
    [t_n, t_n+1)."""
    n1 = states.shape[1]
    sin_wt, cos_wt = np.empty(n1), np.empty(n1)
    moving = np.empty(n1)
    for n in range(n1):  # ω(t − t0) is the same for the whole batch
        arg = omega * (min(n * dt, t_end) - t0)
        sin_wt[n], cos_wt[n] = math.sin(arg), math.cos(arg)
        moving[n] = 1.0 if n * dt < t_end else 0.0
    phi, cos_phi, sin_phi, dphi = np.empty(3), np.empty(3), np.empty(3), np.zeros(3)
    cos_ph, sin_ph = np.empty(3), np.empty(3)
    rate = amplitude * omega
    for k in range(theta.shape[0]):
        for j in range(3):
            cos_ph[j], sin_ph[j] = math.cos(phases[k, j]), math.sin(phases[k, j])
        x, y, psi = start[k, 0], start[k, 1], start[k, 2]
        for n in range(n1):
            for j in range(3):  # sin and cos of ω(t − t0) + ϕ_j by angle addition
                phi[j] = amplitude * (sin_wt[n] * cos_ph[j] + cos_wt[n] * sin_ph[j])
                if complete:
                    dphi[j] = moving[n] * rate * (cos_wt[n] * cos_ph[j] - sin_wt[n] * sin_ph[j])
            row = states[k, n]
            row[0], row[1], row[2] = x, y, psi
            row[3], row[4], row[5] = phi[0], phi[1], phi[2]
            if n == n1 - 1:
                break
            for j in range(3):
                cos_phi[j], sin_phi[j] = math.cos(phi[j]), math.sin(phi[j])
            vx, vy, w = shape_twist(cos_phi, sin_phi, theta[k], dphi, geo)
            c, s = math.cos(psi), math.sin(psi)
            x += dt * (c * vx - s * vy)
            y += dt * (s * vx + c * vy)
            psi += dt * w

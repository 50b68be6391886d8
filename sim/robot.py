"""Robot geometry and the batched no-side-slip kinematics of docs/robot-model.md.

Every function here works on stacks: a leading batch shape ``[...]`` over rollouts (and time)
with the robot's own axes last. The body-frame twist of a shape does not depend on the pose
(the constraint rows rotate with ψ), so twists are solved once in the body frame and rotated.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

N_UNITS = 4
N_JOINTS = 3


@dataclass(frozen=True)
class RobotGeometry:
    """Physical parameters of the robot (docs/robot-model.md, the table) and its footprint."""

    screw_radius: float = 0.075
    front_length: float = 0.103  # l1: front joint -> screw centre
    rear_length: float = 0.123  # l2: screw centre -> rear joint
    head_offset: float = 0.0  # L0: tracked point ahead of unit 1's front joint
    blade_angles: tuple[float, float, float, float] = (
        -math.pi / 4,
        math.pi / 4,
        -math.pi / 4,
        math.pi / 4,
    )
    unit_radius: float = 0.075  # footprint capsule radius of each unit
    head_length: float = 0.055  # head ahead of the tracked point
    head_radius: float = 0.05
    joint_limit: float = math.pi / 2  # physical yaw range
    singular_margin: float = 0.05  # keep |φ| <= limit - margin (all-parallel axles are singular)
    max_screw_speed: float = 1.0  # rad/s
    rcond: float = 1e-6  # relative singular-value cut-off of the least-squares solve
    alpha: Array = field(init=False, repr=False, compare=False)
    segments: Array = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "alpha", np.asarray(self.blade_angles, dtype=float))
        seg = np.array([self.head_offset + self.unit_length, self.unit_length, self.unit_length])
        object.__setattr__(self, "segments", seg)

    @property
    def unit_length(self) -> float:
        return self.front_length + self.rear_length

    @property
    def max_joint_angle(self) -> float:
        """Largest joint angle the simulator applies (singular shapes lie at exactly ±π/2)."""
        return self.joint_limit - self.singular_margin

    @property
    def body_length(self) -> float:
        return self.head_length + self.head_offset + N_UNITS * self.unit_length


DEFAULT_GEOMETRY = RobotGeometry()


def unit_headings(phi: Array) -> Array:
    """Relative headings θ_i − ψ of the four units, ``[..., 4]`` from joint angles ``[..., 3]``."""
    zeros = np.zeros((*phi.shape[:-1], 1))
    return np.concatenate([zeros, np.cumsum(phi, axis=-1)], axis=-1)


# Unit i's moment arms involve segments j < i: the six (i, j) pairs, in a fixed order.
_PAIR_I = np.array([1, 2, 2, 3, 3, 3])
_PAIR_J = np.array([0, 0, 1, 0, 1, 2])
# Row sums S_ij -> Σ_{j<i} S_ij (the ψ̇ column m_i).
_ARM_SUM = np.zeros((6, N_UNITS))
_ARM_SUM[np.arange(6), _PAIR_I] = 1.0
# S_ij -> c_ik = Σ_{k<j<i} S_ij for k < i (the joint-rate columns, flattened i*3 + k).
_JOINT_SUM = np.zeros((6, N_UNITS * N_JOINTS))
for _p, (_i, _j) in enumerate(zip(_PAIR_I, _PAIR_J, strict=True)):
    for _k in range(_j):
        _JOINT_SUM[_p, _i * N_JOINTS + _k] = 1.0
_BELOW_DIAGONAL = np.tril(np.ones((N_UNITS, N_JOINTS)), k=-1)


def _pair_arms(phi: Array, geometry: RobotGeometry) -> tuple[Array, Array]:
    """Wheel-axle directions ``a`` ``[..., 4]`` and the arms ``S_ij`` of the six pairs ``[N, 6]``."""
    th = unit_headings(phi)  # [..., 4]
    a = geometry.alpha + th
    s = geometry.segments[_PAIR_J] * np.sin(a[..., _PAIR_I] - th[..., _PAIR_J])
    return a, s.reshape(-1, 6)  # 2-D so the small matmuls below run as one BLAS call


def constraint_columns(
    phi: Array, geometry: RobotGeometry = DEFAULT_GEOMETRY
) -> tuple[Array, Array, Array]:
    """The columns of ``A_b``: ``cos a``, ``sin a`` and the ψ̇ arms ``m``, ``[..., 4]`` each."""
    return _columns(*_pair_arms(phi, geometry), geometry)


def _columns(a: Array, s: Array, geometry: RobotGeometry) -> tuple[Array, Array, Array]:
    l1_sin = geometry.front_length * np.sin(geometry.alpha)
    m = l1_sin + (s @ _ARM_SUM).reshape(a.shape)
    return np.cos(a), np.sin(a), m


def joint_rate_matrix(phi: Array, geometry: RobotGeometry = DEFAULT_GEOMETRY) -> Array:
    """``A_j`` ``[..., 4, 3]``: how joint rates move each unit's wheel contact (complete mode)."""
    return _joint_rates(_pair_arms(phi, geometry)[1], phi.shape[:-1], geometry)


def _joint_rates(s: Array, batch: tuple[int, ...], geometry: RobotGeometry) -> Array:
    l1_sin = geometry.front_length * np.sin(geometry.alpha)
    aj = (s @ _JOINT_SUM).reshape((*batch, N_UNITS, N_JOINTS))
    out: Array = aj + l1_sin[:, None] * _BELOW_DIAGONAL
    return out


def constraint_matrices(
    phi: Array, geometry: RobotGeometry = DEFAULT_GEOMETRY
) -> tuple[Array, Array]:
    """Body-frame (ψ = 0) constraint matrices ``A_b, A_j``, each ``[..., 4, 3]``.

    Row i is ``cos(θ_i+α_i)·ẋ + sin(θ_i+α_i)·ẏ + m_i·ψ̇ + Σ_{k<i} c_ik·φ̇_k`` (docs/robot-model.md, "Motion"),
    with ``m_i = l1 sin α_i + Σ_{j<i} S_ij``, ``c_ik = l1 sin α_i + Σ_{k<j<i} S_ij`` and
    ``S_ij = s_j sin(α_i + θ_i − θ_j)``.
    """
    ab = np.stack(constraint_columns(phi, geometry), axis=-1)
    return ab, joint_rate_matrix(phi, geometry)


def body_twist(
    theta: Array,
    phi: Array,
    dphi: Array | None = None,
    geometry: RobotGeometry = DEFAULT_GEOMETRY,
) -> Array:
    """Least-squares body-frame twist ``[vx, vy, ψ̇]`` (``[..., 3]``) of shapes ``phi``.

    ``theta`` are the screw speeds ``[..., 4]``; ``dphi`` the joint rates for the complete mode
    (``None`` is the paper-compatible quasi-static mode). The world velocity is R(ψ)·(vx, vy).
    """
    a, s = _pair_arms(phi, geometry)
    rhs = screw_rhs(theta, geometry)
    if dphi is not None:
        rhs = rhs - (_joint_rates(s, phi.shape[:-1], geometry) @ dphi[..., None])[..., 0]
    return least_squares(_columns(a, s, geometry), rhs, geometry.rcond)


def screw_rhs(theta: Array, geometry: RobotGeometry = DEFAULT_GEOMETRY) -> Array:
    """``B·u``: what the screw speeds ``theta`` ``[..., 4]`` drive (the right-hand side)."""
    out: Array = -geometry.screw_radius * np.sin(geometry.alpha) * theta
    return out


def shape_solver(phi: Array, geometry: RobotGeometry = DEFAULT_GEOMETRY) -> NormalSolver:
    """The quasi-static ``body_twist`` of shapes ``phi`` for any screw speeds:
    ``shape_solver(phi).solve(screw_rhs(theta))`` is ``body_twist(theta, phi)``, float for
    float."""
    return NormalSolver(constraint_columns(phi, geometry), geometry.rcond)


# Below this det(AᵀA)/(tr(AᵀA)/3)³ the normal equations lose digits; such shapes take the SVD.
WELL_CONDITIONED = 1e-6


def _dot(u: Array, v: Array) -> Array:
    """Dot products over the last axis (einsum is ~3x faster than (u * v).sum(-1) here)."""
    out: Array = np.einsum("...k,...k->...", u, v)
    return out


def least_squares(columns: tuple[Array, Array, Array], b: Array, rcond: float) -> Array:
    """Minimum-norm least-squares solutions of stacked 4×3 systems ``A x = b`` (== lstsq(rcond)).

    ``A`` is given by its three columns, ``[..., 4]`` each. Well-conditioned systems (every shape within the learning clamp) are solved through the
    normal equations with a closed-form 3×3 inverse, written out element-wise because that
    vectorises far better than thousands of tiny matmuls or SVDs; the rest go through ``pinv``
    with the relative cut-off ``rcond``.
    """
    return NormalSolver(columns, rcond).solve(b)


class NormalSolver:
    """``least_squares`` of fixed columns, for any right-hand side: the normal equations'
    adjugate and determinant made once (``solve`` then does what ``least_squares`` does after
    them, the same operations: the same floats). A body holding its shape moves under many
    screw speeds with one ``A``."""

    def __init__(self, columns: tuple[Array, Array, Array], rcond: float) -> None:
        self.columns, self.rcond = columns, rcond
        c0, c1, c2 = columns
        m00, m11, m22 = _dot(c0, c0), _dot(c1, c1), _dot(c2, c2)
        m01, m02, m12 = _dot(c0, c1), _dot(c0, c2), _dot(c1, c2)
        # Adjugate of the symmetric matrix M = AᵀA.
        i00, i11, i22 = m11 * m22 - m12 * m12, m00 * m22 - m02 * m02, m00 * m11 - m01 * m01
        i01, i02, i12 = m02 * m12 - m01 * m22, m01 * m12 - m02 * m11, m01 * m02 - m00 * m12
        self.adjugate = (i00, i01, i02, i11, i12, i22)
        det = m00 * i00 + m01 * i01 + m02 * i02
        scale = (m00 + m11 + m22) / 3.0
        self.good = det > WELL_CONDITIONED * scale**3
        self.inv_det = 1.0 / np.where(self.good, det, 1.0)
        self.all_good = bool(np.all(self.good))

    def solve(self, b: Array) -> Array:
        """The solutions for the right-hand sides ``b`` ``[..., 4]``."""
        c0, c1, c2 = self.columns
        i00, i01, i02, i11, i12, i22 = self.adjugate
        inv_det = self.inv_det
        r0, r1, r2 = _dot(c0, b), _dot(c1, b), _dot(c2, b)
        x: Array = np.stack(
            [
                (i00 * r0 + i01 * r1 + i02 * r2) * inv_det,
                (i01 * r0 + i11 * r1 + i12 * r2) * inv_det,
                (i02 * r0 + i12 * r1 + i22 * r2) * inv_det,
            ],
            axis=-1,
        )
        if not self.all_good:
            bad = ~self.good
            a = np.stack([np.broadcast_to(c, b.shape)[bad] for c in self.columns], axis=-1)
            pinv = np.linalg.pinv(a, rtol=self.rcond)
            x[bad] = (pinv @ b[bad][..., None])[..., 0]
        return x


def rotate(vectors: Array, angle: Array) -> Array:
    """Rotate 2-vectors ``[..., 2]`` by ``angle`` ``[...]`` (counter-clockwise)."""
    c, s = np.cos(angle), np.sin(angle)
    x, y = vectors[..., 0], vectors[..., 1]
    return np.stack([c * x - s * y, s * x + c * y], axis=-1)


def joint_positions(pose: Array, phi: Array, geometry: RobotGeometry = DEFAULT_GEOMETRY) -> Array:
    """Tracked point and the joints J_1..J_4 (tail end), ``[..., 5, 2]``, for poses ``[..., 3]``."""
    th = pose[..., 2:3] + unit_headings(phi)  # [..., 4]
    seg = np.concatenate([geometry.segments, [geometry.unit_length]])  # unit 4's rear end too
    steps = seg * np.stack([np.cos(th), np.sin(th)], axis=-1).swapaxes(-1, -2)  # [..., 2, 4]
    offsets = np.cumsum(steps.swapaxes(-1, -2), axis=-2)  # [..., 4, 2]
    origin = pose[..., None, :2]
    return np.concatenate([origin, origin + offsets], axis=-2)


def head_tip(pose: Array, geometry: RobotGeometry = DEFAULT_GEOMETRY) -> Array:
    """The head's front point (where the IR sensor sits): ahead of the tracked point."""
    forward = pose[..., 2] + math.pi
    return pose[..., :2] + geometry.head_length * np.stack(
        [np.cos(forward), np.sin(forward)], axis=-1
    )


def body_chain(pose: Array, phi: Array, geometry: RobotGeometry) -> Array:
    """The head tip and the ``joint_positions`` of one pose ``[3]`` and shape ``[3]``, as one
    array ``[6, 2]``: the same operations as ``head_tip`` and ``joint_positions`` element by
    element (the five angles' cos and sin in one numpy call, the sums in the cumulative sums'
    order), on Python floats, far cheaper for one robot."""
    x, y, psi = pose.tolist()
    p0, p1, p2 = phi.tolist()
    h2 = p0 + p1
    angles = np.array([psi + 0.0, psi + p0, psi + h2, psi + (h2 + p2), psi + math.pi])
    cos, sin = np.cos(angles).tolist(), np.sin(angles).tolist()
    seg = [*geometry.segments.tolist(), geometry.unit_length]
    hl = geometry.head_length
    points = [x + hl * cos[4], y + hl * sin[4], x, y]
    ox = oy = 0.0
    for i in range(4):
        # cumsum adds from the first term: 0 + a == a, so start from the first step itself
        sx, sy = seg[i] * cos[i], seg[i] * sin[i]
        ox, oy = (sx, sy) if i == 0 else (ox + sx, oy + sy)
        points += (x + ox, y + oy)
    return np.array(points).reshape(6, 2)


def unit_centres(pose: Array, phi: Array, geometry: RobotGeometry = DEFAULT_GEOMETRY) -> Array:
    """Screw centres p_1..p_4 (docs/robot-model.md), ``[..., 4, 2]``, for poses ``[..., 3]``."""
    th = pose[..., 2:3] + unit_headings(phi)  # [..., 4]
    axes = np.stack([np.cos(th), np.sin(th)], axis=-1)  # [..., 4, 2]
    rear = joint_positions(pose, phi, geometry)[..., :-1, :]  # J_0 (tracked point) .. J_3
    out: Array = rear + geometry.front_length * axes
    return out


def centroid_offset(phi: Array, geometry: RobotGeometry = DEFAULT_GEOMETRY) -> Array:
    """Body-frame (ψ = 0) offset ``[..., 2]`` from the tracked point to the body centroid, the
    mean of the four unit centres; (0.442, 0) for the straight shape."""
    phi = np.asarray(phi, dtype=float)
    zero = np.zeros((*phi.shape[:-1], 3))
    out: Array = unit_centres(zero, phi, geometry).mean(axis=-2)
    return out


def centroid(pose: Array, phi: Array, geometry: RobotGeometry = DEFAULT_GEOMETRY) -> Array:
    """World position ``[..., 2]`` of the body centroid at poses ``[..., 3]`` with joints ``phi``."""
    pose = np.asarray(pose, dtype=float)
    out: Array = pose[..., :2] + rotate(centroid_offset(phi, geometry), pose[..., 2])
    return out

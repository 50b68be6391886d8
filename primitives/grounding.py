"""Grounding a planned motion from where the robot really is: a library primitive as it is,
or an interpolation of library primitives that corrects the offset.

Everything used here comes from library entries: their parameters, durations and the end
poses recorded when they were learned. For a fixed shape the body twist is linear in the screw
speeds, so a weighted sum of primitives' parameters moves by the same weighted sum of their
recorded motions (in the Lie algebra of SE(2), exact while the weights keep the twist
constant). A correction is the planned primitive plus small library translations and a small
library turn, weighted so their recorded motions add up to the offset still to go: the same
kind of blend as the paper's bilinear interpolation (eqs. 16-18), with f(O) = 0.

A periodic shape's primitives share their phases and run whole gait cycles: the body-frame
twist at every instant of the cycle is linear in the screw speeds, so the same blend holds
(to first order in the heading's change), and a blend too fast for the screws is stretched by
whole cycles, the gait's start shape kept at both ends.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from primitives.library import Primitive
from sim.controls import GAIT_CYCLE, Control, FixedShape, PeriodicGait
from sim.robot import Array

TICK = 0.25  # model seconds: durations are whole control ticks
MAX_SPEED = 0.95  # rad/s: a blend faster than this is stretched in time instead
LIBRARY_MATCH = (0.004, math.radians(0.3))  # offsets within this run the primitive as it is


def twist_of(end_pose: Sequence[float] | Array) -> Array:
    """The SE(2) logarithm of a start-frame end pose: (vx, vy, ω)·T of a constant twist."""
    dx, dy, w = (float(v) for v in end_pose)
    if abs(w) < 1e-9:
        return np.array([dx, dy, 0.0])
    a = w / 2
    c = a / math.tan(a)  # V⁻¹ = [[c, a], [-a, c]] for the SE(2) exponential
    return np.array([c * dx + a * dy, -a * dx + c * dy, w])


@dataclass(frozen=True)
class Grounded:
    """What the executor runs for one move: screw speeds with joints held (or a gait of
    ``cycles`` whole cycles from ``phases``, starting and ending in ``joints``), for a
    duration."""

    theta: Array
    joints: Array
    duration: float
    method: str  # "library" or "interpolated"
    primitives: tuple[str, ...]
    expected: Array  # start-frame end pose the library data predict
    phases: Array | None = None
    cycles: int = 0

    def control(self, t0: float = 0.0) -> Control:
        """The control of the move started at model time ``t0`` (a gait's clock)."""
        if self.phases is None:
            return FixedShape.of(self.theta, self.joints)
        t_end = t0 + self.cycles * GAIT_CYCLE
        return PeriodicGait.of(self.theta, self.phases, t0=t0, t_end=t_end)

    def to_dict(self) -> dict[str, object]:
        return {
            "method": self.method,
            "primitives": list(self.primitives),
            "duration": self.duration,
        }


def gait_duration(cycles: int) -> float:
    """Whole control ticks covering ``cycles`` gait cycles (the last tick holds the start
    shape for what is left of it)."""
    return math.ceil(cycles * GAIT_CYCLE / TICK - 1e-9) * TICK


def _exp(xi: Array) -> Array:
    vx, vy, w = xi
    if abs(w) < 1e-9:
        return np.array([vx, vy, 0.0])
    s, c = math.sin(w), math.cos(w)
    return np.array([(s * vx - (1 - c) * vy) / w, ((1 - c) * vx + s * vy) / w, w])


def correction_basis(entries: Sequence[Primitive]) -> list[Primitive]:
    """The shortest translations and the smallest turns of a shape: what corrections use."""
    moves = [e for e in entries if e.turn == 0.0]
    turns = [e for e in entries if e.turn != 0.0]
    shortest = min((math.hypot(*e.goal) for e in moves), default=0.0)
    smallest = min((abs(e.turn) for e in turns), default=0.0)
    basis = [e for e in moves if math.hypot(*e.goal) <= shortest + 1e-9]
    basis += [e for e in turns if abs(e.turn) <= smallest + 1e-9]
    return basis


def ground(
    offset: Sequence[float] | Array, basis: Sequence[Primitive], planned: Primitive | None = None
) -> Grounded:
    """Parameters that end at ``offset`` (start frame of the current pose).

    With ``planned``: that primitive as it is when it lands close enough, else blended with
    ``basis`` (see ``correction_basis``) to make up the difference. Without: a blend of
    ``basis`` alone (a final approach to a goal).
    """
    want = np.asarray(offset, dtype=float)
    if planned is None and not basis:
        raise ValueError("basis: no library primitives to blend")
    first = planned if planned is not None else basis[0]
    joints = np.asarray(first.rest_joints, dtype=float)
    phases = None if first.phases is None else np.asarray(first.phases, dtype=float)
    cycles = first.cycles
    if planned is not None:
        assert planned.end_pose is not None and (planned.joints or planned.cycles)
        duration = float(planned.rollout.duration)
        theta = np.asarray(planned.theta, dtype=float)
        base = twist_of(planned.end_pose)
        used = [planned.id]
        miss = want - np.asarray(planned.end_pose)
        if math.hypot(miss[0], miss[1]) <= LIBRARY_MATCH[0] and abs(miss[2]) <= LIBRARY_MATCH[1]:
            return Grounded(
                theta, joints, duration, "library", (planned.id,), _exp(base), phases, cycles
            )
    else:
        duration = max(float(e.rollout.duration) for e in basis)
        theta = np.zeros(4)
        base, used = np.zeros(3), []
    delta = twist_of(want) - base
    # Each basis primitive b adds w·ξ_b when run at w·T_b/T of its speeds over the duration T.
    blend = _blend_of(basis)
    xis = blend.twists
    weights = _weights(blend, delta)
    for w, e in zip(weights, basis, strict=True):
        if abs(w) > 1e-9:
            theta = theta + w * np.asarray(e.theta) * (float(e.rollout.duration) / duration)
            used.append(e.id)
    expected = _exp(base + xis.T @ weights)
    peak = max((abs(v) for v in theta.tolist()), default=0.0)
    if peak > MAX_SPEED and cycles:  # the same motion, slower: in more whole gait cycles
        more = math.ceil(cycles * peak / MAX_SPEED - 1e-9)
        theta, cycles, duration = theta * (cycles / more), more, gait_duration(more)
    elif peak > MAX_SPEED:  # the same motion, slower: stretch the duration to whole ticks
        stretched = math.ceil(duration * peak / MAX_SPEED / TICK - 1e-9) * TICK
        theta, duration = theta * (duration / stretched), stretched
    return Grounded(theta, joints, duration, "interpolated", tuple(used), expected, phases, cycles)


@dataclass(frozen=True)
class _Blend:
    """What a blend reads of its basis, made once per basis: each primitive's recorded twist
    ``[B, 3]``, which are translations and which turns, and each translation's direction."""

    twists: Array
    translations: tuple[int, ...]
    turns: tuple[int, ...]
    directions: tuple[float, ...]  # atan2 of each translation's twist, in ``translations``' order


_BLENDS: dict[tuple[object, ...], _Blend] = {}
BLENDS_KEPT = 64  # bases remembered (one per shape and library version in use)


def _blend_of(basis: Sequence[Primitive]) -> _Blend:
    """The basis' ``_Blend``, remembered by what it is made of (a correction blends the same
    few primitives at every move)."""
    key = tuple((e.id, e.end_pose, e.turn) for e in basis)
    got = _BLENDS.get(key)
    if got is None:
        twists = np.array([twist_of(e.end_pose or (0.0, 0.0, 0.0)) for e in basis])  # [B, 3]
        twists.flags.writeable = False  # shared by every grounding with this basis
        translations = tuple(b for b, e in enumerate(basis) if e.turn == 0.0)
        turns = tuple(b for b, e in enumerate(basis) if e.turn != 0.0)
        directions = tuple(math.atan2(twists[b, 1], twists[b, 0]) for b in translations)
        if len(_BLENDS) >= BLENDS_KEPT:
            _BLENDS.clear()
        got = _BLENDS[key] = _Blend(twists, translations, turns, directions)
    return got


def _sign(x: float) -> int:
    return (x > 0) - (x < 0)


def _weights(blend: _Blend, delta: Array) -> Array:
    """Weights of at most three basis primitives (the two translations bracketing the missing
    translation's direction, and a turn for the missing rotation), least squares otherwise."""
    xis = blend.twists
    out = np.zeros(len(xis))
    if len(xis) == 0:
        return out
    pick: list[int] = []
    dx, dy, dw = (float(v) for v in delta)
    if len(blend.translations) >= 2 and math.hypot(dx, dy) > 1e-9:
        angle = math.atan2(dy, dx)
        right = left = -1  # the nearest on either side (the first of equals)
        right_gap = left_gap = 0.0
        for b, direction in zip(blend.translations, blend.directions, strict=True):
            gap = math.remainder(direction - angle, 2 * math.pi)
            if gap <= 0:
                if right < 0 or gap > right_gap:
                    right, right_gap = b, gap
            elif left < 0 or gap < left_gap:
                left, left_gap = b, gap
        if right >= 0 and left >= 0:
            pick += [right, left]
    if blend.turns and abs(dw) > 1e-4:
        # the turn the right way, the smallest (the first of equals)
        turn = min(
            blend.turns, key=lambda b: (_sign(float(xis[b, 2])) != _sign(dw), abs(xis[b, 2]))
        )
        pick.append(turn)
    chosen = pick if pick else list(range(len(xis)))
    solved = _small_least_squares([xis[b] for b in chosen], (dx, dy, dw))
    if solved is None:  # many columns, or (nearly) dependent ones: numpy's SVD least squares
        out[chosen] = np.linalg.lstsq(xis[chosen].T, delta, rcond=None)[0]
    else:
        out[chosen] = solved
    return out


# Below this (relative to the columns' scale) a blend's columns count as dependent.
DEPENDENT = 1e-9


Vector3 = tuple[float, float, float]


def _dot3(u: Vector3, v: Vector3) -> float:
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]


def _det3(u: Vector3, v: Vector3, w: Vector3) -> float:
    """``det [u v w]`` (columns), expanded along the first row."""
    return (
        u[0] * (v[1] * w[2] - v[2] * w[1])
        - v[0] * (u[1] * w[2] - u[2] * w[1])
        + w[0] * (u[1] * v[2] - u[2] * v[1])
    )


def _small_least_squares(columns: list[Array], rhs: Vector3) -> list[float] | None:
    """The least-squares weights of up to three twist columns ``[3]`` for ``rhs``, in closed
    form (a blend's system: numpy's general solver costs ~30 us of setup for it), or None
    for more columns or nearly dependent ones. One or two columns: the normal equations; three:
    Cramer's rule on the columns themselves (the exact solution, as well conditioned as they
    are)."""
    cols = [(float(c[0]), float(c[1]), float(c[2])) for c in columns]
    if len(cols) == 1:
        (u,) = cols
        uu = _dot3(u, u)
        return [_dot3(u, rhs) / uu] if uu > 0.0 else None
    if len(cols) == 2:
        u, v = cols
        uu, vv, uv = _dot3(u, u), _dot3(v, v), _dot3(u, v)
        det = uu * vv - uv * uv
        if not det > DEPENDENT * uu * vv:
            return None
        ub, vb = _dot3(u, rhs), _dot3(v, rhs)
        return [(vv * ub - uv * vb) / det, (uu * vb - uv * ub) / det]
    if len(cols) == 3:
        u, v, w = cols
        det = _det3(u, v, w)
        if not abs(det) > DEPENDENT * math.sqrt(_dot3(u, u) * _dot3(v, v) * _dot3(w, w)):
            return None
        return [_det3(rhs, v, w) / det, _det3(u, rhs, w) / det, _det3(u, v, rhs) / det]
    return None

"""Grounding move(direction, shape) for one control interval from the library's primitives.

A primitive is learned for a whole rollout, but an executor re-grounds every control interval,
so what matters is where a primitive *starts* to go. Each primitive's initial velocity is
measured once from a short rollout of it. For a wanted direction we blend the two primitives
of the shape whose initial velocities bracket it: the body twist is linear in the screw speeds,
so a·θ_i + b·θ_j moves at a·v_i + b·v_j. This is interpolation between library entries (their
measured behaviour), never an inversion of the kinematic model. Periodic primitives cannot be
blended (their phases are not linear): the one pointing nearest is scaled instead.

A third primitive joins the pair to cancel the turn rate (three weights for vx, vy and ψ̇ = 0,
as the paper's bilinear interpolation also combines three primitives): a body that keeps its
heading sweeps less space and keeps the planner's clearance checks valid.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from primitives.library import Library, Primitive
from sim.robot import Array
from sim.rollout import RolloutConfig, rollout

PROBE = RolloutConfig(duration=1.0, dt=1.0)
PERIODIC_PROBE = RolloutConfig(duration=2 * math.pi / 0.6, dt=0.25)  # one gait cycle


@dataclass(frozen=True)
class Command:
    """Screw speeds (and joints or phases) for the next interval, with what they came from."""

    theta: Array
    joints: Array | None
    phases: Array | None
    sources: tuple[str, ...]
    method: str  # "library" or "interpolated"

    def grounding(self) -> dict[str, object]:
        return {"method": self.method, "primitives": list(self.sources)}


class Steering:
    """Initial velocities of a library's primitives, and commands blended from them."""

    def __init__(self, library: Library) -> None:
        self.library = library
        self._velocity: dict[str, Array] = {}
        self._turn: dict[str, float] = {}
        for entry in library:
            config = PERIODIC_PROBE if entry.periodic else PROBE
            end = rollout(entry.control(), config=config).end[0]
            self._velocity[entry.id] = end[:2] / config.duration  # start frame, m/s
            self._turn[entry.id] = float(end[2]) / config.duration  # rad/s

    def velocity(self, entry: Primitive) -> Array:
        return self._velocity[entry.id]

    def command(
        self,
        shape: str,
        direction: float,
        speed: float,
        joints: Array | None = None,
        max_speed: float = 0.8,
    ) -> Command:
        """Move at ``direction`` (radians, start frame of the current pose) at ``speed`` m/s.

        ``joints`` overrides the shape's joints (a deformed body close to a library shape);
        screw speeds are scaled down so that none exceeds ``max_speed`` rad/s.
        """
        entries = [
            e for e in self.library.of_shape(shape) if np.linalg.norm(self._velocity[e.id]) > 1e-9
        ]
        if not entries:
            raise KeyError(f"the library has no primitives of shape {shape!r}")
        want = speed * np.array([math.cos(direction), math.sin(direction)])
        if entries[0].periodic:
            best = min(entries, key=lambda e: _gap(self._velocity[e.id], direction))
            v = self._velocity[best.id]
            theta = np.array(best.theta) * (speed / float(np.linalg.norm(v)))
            return self._finish(
                theta, None, np.array(best.phases), (best.id,), "library", max_speed
            )
        first, second = _bracket(entries, [self._velocity[e.id] for e in entries], direction)
        basis = np.array([self._velocity[first.id], self._velocity[second.id]]).T
        sources: tuple[str, ...]
        if abs(np.linalg.det(basis)) < 1e-12 or first is second:
            scale = speed / float(np.linalg.norm(self._velocity[first.id]))
            theta, sources, method = np.array(first.theta) * scale, (first.id,), "library"
        else:
            theta, sources = self._blend(entries, first, second, want)
            method = "interpolated"
        held = np.array(first.joints) if joints is None else np.asarray(joints, dtype=float)
        return self._finish(theta, held, None, sources, method, max_speed)

    def _blend(
        self, entries: list[Primitive], first: Primitive, second: Primitive, want: Array
    ) -> tuple[Array, tuple[str, ...]]:
        """The bracketing pair plus the third primitive that best cancels the turn rate."""
        best: tuple[float, Array, tuple[str, ...]] | None = None
        for third in entries:
            if third is first or third is second:
                continue
            trio = (first, second, third)
            rows = np.array([[*self._velocity[e.id], self._turn[e.id]] for e in trio]).T  # [3, 3]
            if abs(np.linalg.det(rows)) < 1e-12:
                continue
            w = np.linalg.solve(rows, np.append(want, 0.0))
            theta = np.sum([wi * np.array(e.theta) for wi, e in zip(w, trio, strict=True)], axis=0)
            peak = float(np.max(np.abs(theta)))
            if best is None or peak < best[0]:
                best = (peak, theta, tuple(e.id for e in trio))
        if best is not None:
            return best[1], best[2]
        a, b = np.linalg.solve(
            np.array([self._velocity[first.id], self._velocity[second.id]]).T, want
        )
        return a * np.array(first.theta) + b * np.array(second.theta), (first.id, second.id)

    @staticmethod
    def _finish(
        theta: Array,
        joints: Array | None,
        phases: Array | None,
        sources: tuple[str, ...],
        method: str,
        max_speed: float,
    ) -> Command:
        peak = float(np.max(np.abs(theta)))
        if peak > max_speed:
            theta = theta * (max_speed / peak)
        return Command(theta, joints, phases, sources, method)


def _gap(v: Array, direction: float) -> float:
    return abs(math.remainder(math.atan2(v[1], v[0]) - direction, 2 * math.pi))


def _bracket(
    entries: list[Primitive], velocities: list[Array], direction: float
) -> tuple[Primitive, Primitive]:
    offsets = [math.remainder(math.atan2(v[1], v[0]) - direction, 2 * math.pi) for v in velocities]
    right = [i for i, o in enumerate(offsets) if o <= 0]
    left = [i for i, o in enumerate(offsets) if o > 0]
    if not right or not left:
        i = int(np.argmin(np.abs(offsets)))
        return entries[i], entries[i]
    i = max(right, key=lambda k: offsets[k])
    j = min(left, key=lambda k: offsets[k])
    if offsets[j] - offsets[i] >= math.pi:  # the pair does not span the direction within 180°
        k = i if -offsets[i] < offsets[j] else j
        return entries[k], entries[k]
    return entries[i], entries[j]

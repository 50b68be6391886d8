"""The paper's moves from library data alone: a Table 2 primitive as it is, or an IM
interpolated with eqs. 16-18 towards a direction, each with the motion the library predicts.

A paper primitive carries the robot from the start pose to its recorded ``end`` in
``rollout.duration`` seconds; its mean velocity (start frame) is ``end / duration``. An IM's
predicted end is the same bilinear blend of its sources' recorded ends (f(O) = 0) as of their
parameters. ``split`` decomposes an offset into a run of one move followed by a run of another
(Fig. 9b: back to Set 1 for a time-out, then P6s) with the library's velocities.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from primitives.catalogue import FIG6_GOALS
from primitives.interpolation import (
    QUADRANT_GOALS,
    QUADRANTS,
    bilinear,
    corners_of,
    interpolate_entries,
    quadrant_of,
)
from primitives.library import Library, Primitive
from sim.robot import Array

QUADRANT_SIZE = 2.0  # m: the paper interpolates within 2 m x 2 m quadrants (§5.2)
LIBRARY_ANGLE = math.radians(3.0)  # a direction this close to a primitive's runs it as it is
QUADRANT_SLACK = math.radians(20.0)  # how far past its axes a re-aimed move keeps a quadrant
PREFER_ANGLE = math.radians(15.0)  # ... and this close to a primitive the mission selected


@dataclass(frozen=True)
class Move:
    """Parameters for a fixed body shape and the start-frame velocity the library predicts."""

    theta: Array
    joints: Array
    shape: str
    method: str  # "library" | "interpolated"
    primitives: tuple[str, ...]  # library ids (the sources of an interpolation)
    velocity: Array  # m/s, start frame of the pose the move starts from
    target: tuple[float, float]  # start-frame point the move is aimed at (100 s of it)
    quadrant: str = ""  # the quadrant an interpolation was made in

    @property
    def direction(self) -> float:
        """Start-frame direction of motion, radians counter-clockwise from +x."""
        return math.atan2(float(self.velocity[1]), float(self.velocity[0]))

    def grounding(self) -> dict[str, object]:
        """What the plan and the mission log show: method, library ids and the direction in
        the paper's labels (degrees clockwise from the head: P2 is 90°, P4 0°, P6 −90°)."""
        return {
            "method": self.method,
            "primitives": list(self.primitives),
            "towards_deg": round(paper_angle(self.target), 1),
        }


def paper_angle(offset: Sequence[float]) -> float:
    """A start-frame direction in the paper's labels: degrees from the head (−x), clockwise
    in our frame (docs/robot-model.md, "Frames and the paper's angle labels"), in (−180, 180]."""
    ours = math.degrees(math.atan2(float(offset[1]), float(offset[0])))
    return 0.0 - math.remainder(ours - 180.0, 360.0) + 0.0


def of_entry(entry: Primitive) -> Move:
    """A library primitive as it is."""
    if entry.periodic or entry.joints is None:
        raise ValueError(f"{entry.name}: a periodic primitive has no fixed shape to hold")
    velocity = np.asarray(entry.end, dtype=float) / float(entry.rollout.duration)
    return Move(
        np.asarray(entry.theta, dtype=float),
        np.asarray(entry.joints, dtype=float),
        entry.shape,
        "library",
        (entry.id,),
        velocity,
        (float(entry.goal[0]), float(entry.goal[1])),
    )


def interpolated(entries: Sequence[Primitive], goal: tuple[float, float]) -> Move:
    """Eqs. 16-18 over three primitives towards ``goal``; the velocity blends their ends."""
    made = interpolate_entries(entries, goal)
    on_x, on_y, diagonal = corners_of(entries)
    ends = [np.asarray(e.end, dtype=float) for e in (on_x, on_y, diagonal)]
    end = bilinear(goal, ends[0], ends[1], ends[2], on_x.goal[0], on_y.goal[1])
    duration = max(float(e.rollout.duration) for e in entries)
    ids = tuple(e.id for e in (on_x, on_y, diagonal))
    return Move(made.theta, made.joints, on_x.shape, "interpolated", ids, end / duration, made.goal)


def quadrant_entries(library: Library, shape: str, quadrant: str) -> list[Primitive]:
    """The Fig. 6 primitives of ``shape`` spanning ``quadrant`` (x axis, y axis, diagonal)."""
    by_goal = {e.goal: e for e in library.of_shape(shape) if not e.periodic}
    try:
        return [by_goal[FIG6_GOALS[i - 1]] for i in QUADRANT_GOALS[quadrant]]
    except KeyError:
        raise KeyError(
            f"the library lacks a Fig. 6 primitive of shape {shape!r} for quadrant {quadrant}"
        ) from None


def aim(
    library: Library,
    shape: str,
    offset: Sequence[float],
    prefer: Primitive | None = None,
    prefer_angle: float = PREFER_ANGLE,
    snap: bool = True,
    keep: str | None = None,
    force_keep: bool = False,
) -> Move:
    """A move of ``shape`` towards the start-frame ``offset``: ``prefer`` (a primitive the
    mission selected, as the paper selects them) when it goes within ``prefer_angle`` of that
    way, else a library primitive within ``LIBRARY_ANGLE``, else the paper's interpolation in
    the quadrant holding the offset, at the quadrant's scale (max(|x|, |y|) = 2 m). Without
    ``snap`` the interpolation is used even next to a primitive (it equals the primitive at
    its corner), so a move re-aimed every tick keeps one set of sources; ``keep`` names the
    quadrant used last, kept while the direction is within ``QUADRANT_SLACK`` of it, or always
    with ``force_keep`` (the offset is then clipped onto that quadrant's axis)."""
    dx, dy = float(offset[0]), float(offset[1])
    want = math.atan2(dy, dx)

    def gap(e: Primitive) -> float:
        return abs(math.remainder(math.radians(e.direction) - want, 2 * math.pi))

    if prefer is not None and prefer.shape == shape and gap(prefer) <= prefer_angle:
        return of_entry(prefer)
    fixed = [e for e in library.of_shape(shape) if not e.periodic]
    if not fixed:
        raise KeyError(f"no fixed-shape primitive of shape {shape!r} in the library")
    closest = min(fixed, key=gap)
    if snap and gap(closest) <= LIBRARY_ANGLE:
        return of_entry(closest)
    scale = QUADRANT_SIZE / max(abs(dx), abs(dy), 1e-9)
    goal = (dx * scale, dy * scale)
    quadrant = quadrant_of(goal)
    if keep is not None and keep != quadrant and (force_keep or _near_quadrant(want, keep)):
        quadrant = keep  # hysteresis: a direction wobbling over an axis keeps its sources
        sx, sy = QUADRANTS[keep]
        goal = (sx * max(sx * goal[0], 0.0), sy * max(sy * goal[1], 0.0))
    return interpolated(quadrant_entries(library, shape, quadrant), goal)


def _near_quadrant(direction: float, quadrant: str) -> bool:
    """Whether ``direction`` lies within ``QUADRANT_SLACK`` of ``quadrant``'s 90° sector."""
    sx, sy = QUADRANTS[quadrant]
    middle = math.atan2(sy, sx)
    return abs(math.remainder(direction - middle, 2 * math.pi)) <= math.pi / 4 + QUADRANT_SLACK


def nearest(library: Library, shape: str, direction: float) -> Move:
    """The primitive of ``shape`` whose start-frame direction is nearest ``direction`` (rad)."""
    fixed = [e for e in library.of_shape(shape) if not e.periodic]
    if not fixed:
        raise KeyError(f"no fixed-shape primitive of shape {shape!r} in the library")
    return of_entry(
        min(
            fixed,
            key=lambda e: abs(math.remainder(math.radians(e.direction) - direction, 2 * math.pi)),
        )
    )


def split(
    offset: Sequence[float] | Array, first: Sequence[float] | Array, second: Sequence[float] | Array
) -> tuple[float, float] | None:
    """Seconds (a, b) with a·first + b·second = offset (velocities, one frame), a, b >= 0."""
    m = np.column_stack([np.asarray(first, dtype=float), np.asarray(second, dtype=float)])
    if abs(float(np.linalg.det(m))) < 1e-12:
        return None
    a, b = np.linalg.solve(m, np.asarray(offset[:2], dtype=float))
    if a < 0 or b < 0:
        return None
    return float(a), float(b)


def to_start_frame(pose: Sequence[float], point: Sequence[float]) -> tuple[float, float]:
    """``point`` (world) as a displacement in the start frame of ``pose``."""
    x, y, psi = (float(v) for v in pose[:3])
    dx, dy = float(point[0]) - x, float(point[1]) - y
    c, s = math.cos(psi), math.sin(psi)
    return (c * dx + s * dy, -s * dx + c * dy)

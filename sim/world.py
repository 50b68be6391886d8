"""The world: rectangular bounds, obstacles, the robot's footprint and collision checks."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from sim.obstacles import Obstacle, ray_segment_hits
from sim.robot import DEFAULT_GEOMETRY, Array, RobotGeometry, head_tip, joint_positions

WALL = -1  # obstacle index reported for the arena bounds


@dataclass(frozen=True)
class Bounds:
    xmin: float = -10.0
    xmax: float = 10.0
    ymin: float = -10.0
    ymax: float = 10.0

    def __post_init__(self) -> None:
        values = (self.xmin, self.xmax, self.ymin, self.ymax)
        if not all(math.isfinite(v) for v in values):
            raise ValueError("bounds: values must be finite")
        if self.xmin >= self.xmax or self.ymin >= self.ymax:
            raise ValueError("bounds: need xmin < xmax and ymin < ymax")

    def corners(self) -> Array:
        return np.array(
            [
                [self.xmin, self.ymin],
                [self.xmax, self.ymin],
                [self.xmax, self.ymax],
                [self.xmin, self.ymax],
            ]
        )

    def wall_clearance(self, points: Array) -> Array:
        """Distance of points ``[..., 2]`` to the nearest wall (negative outside)."""
        x, y = points[..., 0], points[..., 1]
        out: Array = np.minimum(
            np.minimum(x - self.xmin, self.xmax - x), np.minimum(y - self.ymin, self.ymax - y)
        )
        return out

    def contains(self, x: float, y: float, margin: float = 0.0) -> bool:
        return bool(self.wall_clearance(np.array([x, y])) >= margin)


@dataclass(frozen=True)
class Footprint:
    """Capsules covering the robot: segment ends ``[..., 5, 2]`` (head, units 1-4), radii ``[5]``."""

    starts: Array
    ends: Array
    radii: Array


def _point_distance(obstacle: Obstacle) -> Callable[[Array], Array]:
    def distance(points: Array) -> Array:
        p = np.atleast_2d(points)
        return obstacle.segment_clearance(p, p).reshape(np.shape(points)[:-1])

    return distance


def footprint(pose: Array, joints: Array, geometry: RobotGeometry = DEFAULT_GEOMETRY) -> Footprint:
    """The head capsule and the four unit capsules at poses ``[..., 3]`` with ``joints`` ``[3]``."""
    js = joint_positions(pose, joints, geometry)  # [..., 5, 2]
    tip = head_tip(pose, geometry)
    starts = np.concatenate([tip[..., None, :], js[..., :-1, :]], axis=-2)
    ends = np.concatenate([js[..., :1, :], js[..., 1:, :]], axis=-2)
    radii = np.array([geometry.head_radius] + [geometry.unit_radius] * 4)
    return Footprint(starts, ends, radii)


SIDES = ("front", "rear", "left", "right")


@dataclass(frozen=True)
class Contact:
    """The first thing the footprint touches: an obstacle index (or WALL), the body part and
    the side of that part that touched (what a bumper or a stall-current sensor reports)."""

    obstacle: int
    part: int  # 0 = head, 1..4 = units
    side: str = "front"  # one of SIDES, in the part's own frame (front = towards the head)

    @property
    def what(self) -> str:
        return "wall" if self.obstacle == WALL else f"obstacle {self.obstacle}"


@dataclass(frozen=True)
class World:
    bounds: Bounds = field(default_factory=Bounds)
    obstacles: tuple[Obstacle, ...] = ()

    def contact(self, fp: Footprint) -> Contact | None:
        """The first obstacle or wall the footprint overlaps, or ``None`` when it is free."""
        ends = np.concatenate([fp.starts, fp.ends])
        wall = self.bounds.wall_clearance(ends) < np.concatenate([fp.radii, fp.radii])
        if np.any(wall):
            part = int(np.argmax(wall)) % len(fp.radii)
            return Contact(WALL, part, self._side(fp, part, self.bounds.wall_clearance))
        for index, obstacle in enumerate(self.obstacles):
            hit = obstacle.segment_clearance(fp.starts, fp.ends) < fp.radii
            if np.any(hit):
                part = int(np.argmax(hit))
                return Contact(index, part, self._side(fp, part, _point_distance(obstacle)))
        return None

    @staticmethod
    def _side(fp: Footprint, part: int, distance: Callable[[Array], Array]) -> str:
        """Which side of ``part`` faces the thing at ``distance`` (a signed-ish distance field):
        the axis point nearest to it, and the field's gradient there, in the part's frame."""
        start, end = fp.starts[part], fp.ends[part]
        s = np.linspace(0.0, 1.0, 9)
        axis = start + s[:, None] * (end - start)
        k = int(np.argmin(distance(axis)))
        steps = 1e-4 * np.eye(2)
        grad = distance(axis[k] + steps) - distance(axis[k] - steps)  # central differences
        towards = -grad  # the field grows away from the obstacle
        forward = start - end  # capsules run from the head side to the tail side
        along = float(towards @ forward)
        lateral = float(forward[0] * towards[1] - forward[1] * towards[0])
        at_end = k in (0, len(s) - 1)
        if at_end and abs(along) > abs(lateral):
            return "front" if along > 0 else "rear"
        return "left" if lateral > 0 else "right"

    def ray_cast(self, origin: Array, dirs: Array, max_range: float) -> tuple[Array, Array]:
        """First hits of rays ``[R, 2]`` from ``origin``: distances (capped at ``max_range``) and
        what they hit (obstacle index, ``WALL``, or ``-2`` for nothing within range)."""
        corners = self.bounds.corners()
        hits = [ray_segment_hits(origin, dirs, corners, np.roll(corners, -1, axis=0)).min(axis=-1)]
        hits += [obstacle.ray_cast(origin, dirs) for obstacle in self.obstacles]
        table = np.stack(hits, axis=-1)  # [R, 1 + n_obstacles]
        best = np.argmin(table, axis=-1)
        dist = table[np.arange(dirs.shape[0]), best]
        what = np.where(best == 0, WALL, best - 1)
        what = np.where(dist <= max_range, what, -2)
        return np.minimum(dist, max_range), what

    def gap(self, fp: Footprint) -> float:
        """Smallest gap between a footprint and any obstacle or wall (0 if touching)."""
        ends = np.concatenate([fp.starts, fp.ends])
        gap = float(np.min(self.bounds.wall_clearance(ends) - np.tile(fp.radii, 2)))
        for obstacle in self.obstacles:
            gap = min(gap, float(np.min(obstacle.segment_clearance(fp.starts, fp.ends) - fp.radii)))
        return max(gap, 0.0)

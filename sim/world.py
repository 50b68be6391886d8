"""The world: rectangular bounds, obstacles, the robot's footprint and collision checks."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import cast

import numpy as np
from numpy.typing import NDArray

from sim import collision_kernel
from sim.obstacles import Obstacle, ray_segment_hits
from sim.raster import OccupancyRaster
from sim.robot import (
    DEFAULT_GEOMETRY,
    Array,
    RobotGeometry,
    body_chain,
    head_tip,
    joint_positions,
)
from sim.scene import Scene

WALL = -1  # obstacle index reported for the arena bounds
CANDIDATE_SLACK = 0.25  # m a ray origin may move before its candidate obstacles are found anew
SCENES_KEPT = 256  # packed sets of nearby obstacles remembered per world
_NO_CIRCLES = np.zeros((0, 0))


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
    if np.ndim(pose) == 1 and np.ndim(joints) == 1:
        # one body (the simulator's sub-steps, the world model's body cells): the same chain on
        # Python floats, several times cheaper than the batched arrays
        chain = body_chain(np.asarray(pose, dtype=float), np.asarray(joints, dtype=float), geometry)
        return footprint_of_chain(chain, geometry)
    js = joint_positions(pose, joints, geometry)  # [..., 5, 2]
    return footprint_of(js, head_tip(pose, geometry), geometry)


def footprint_of(js: Array, tip: Array, geometry: RobotGeometry = DEFAULT_GEOMETRY) -> Footprint:
    """The footprint from joint positions ``[..., 5, 2]`` and the head tip ``[..., 2]`` already
    computed (the simulator has them at hand)."""
    starts = np.concatenate([tip[..., None, :], js[..., :-1, :]], axis=-2)
    ends = np.concatenate([js[..., :1, :], js[..., 1:, :]], axis=-2)
    return Footprint(starts, ends, footprint_radii(geometry))


def footprint_of_chain(chain: Array, geometry: RobotGeometry = DEFAULT_GEOMETRY) -> Footprint:
    """The footprint of one pose from its chain ``[6, 2]``: the head tip, then the joint
    positions (``footprint_of`` of those, the same capsules as views of one array)."""
    return Footprint(chain[:-1], chain[1:], footprint_radii(geometry))


_RADII: dict[tuple[float, float], Array] = {}


def footprint_radii(geometry: RobotGeometry = DEFAULT_GEOMETRY) -> Array:
    """The capsules' radii ``[5]`` (head, units 1-4): one read-only array per geometry."""
    key = (geometry.head_radius, geometry.unit_radius)
    radii = _RADII.get(key)
    if radii is None:
        radii = np.array([geometry.head_radius] + [geometry.unit_radius] * 4)
        radii.flags.writeable = False
        _RADII[key] = radii
    return radii


SIDES = ("front", "rear", "left", "right")


@dataclass(frozen=True)
class Contact:
    """The first thing the footprint touches: an obstacle index (or WALL), the body part and
    the side of that part that touched (what a bumper or a stall-current sensor reports)."""

    obstacle: int  # a map's cells: len(obstacles) + the map's index
    part: int  # 0 = head, 1..4 = units
    side: str = "front"  # one of SIDES, in the part's own frame (front = towards the head)
    label: str = ""  # what it is when not an obstacle nor the wall ("map 0")

    @property
    def what(self) -> str:
        if self.label:
            return self.label
        return "wall" if self.obstacle == WALL else f"obstacle {self.obstacle}"


@dataclass(frozen=True)
class World:
    """Bounds, obstacles and occupancy maps; collision and ray queries run over all obstacles
    at once (``Scene``) and, for the footprint, over only those whose bounding boxes come near
    it; a map's cells are looked up where the query reaches (``OccupancyRaster``), never
    scanned whole. A map's occupied cells are reported as obstacle ``len(obstacles) + k``
    (map ``k``)."""

    bounds: Bounds = field(default_factory=Bounds)
    obstacles: tuple[Obstacle, ...] = ()
    rasters: tuple[OccupancyRaster, ...] = ()
    _scenes: dict[tuple[int, ...], Scene] = field(
        init=False, repr=False, compare=False, default_factory=dict
    )
    _walls: tuple[Array, Array] = field(init=False, repr=False, compare=False)
    _near_cache: dict[float, tuple[tuple[float, float], NDArray[np.int64], Scene]] = field(
        init=False, repr=False, compare=False, default_factory=dict
    )
    _full: list[tuple[Scene, Array]] = field(
        init=False, repr=False, compare=False, default_factory=list
    )

    def __post_init__(self) -> None:
        corners = self.bounds.corners()
        object.__setattr__(self, "_walls", (corners, np.roll(corners, -1, axis=0)))

    @property
    def _everything(self) -> tuple[Scene, Array]:
        """The scene of every obstacle and the bounds as an array (for the compiled gap)."""
        if not self._full:
            b = self.bounds
            box = np.array([b.xmin, b.xmax, b.ymin, b.ymax])
            self._full.append((self._scene(tuple(range(len(self.obstacles)))), box))
        return self._full[0]

    def _scene(self, indices: tuple[int, ...]) -> Scene:
        """The packed arrays of the obstacles at ``indices`` (cached: a mission meets few sets)."""
        scene = self._scenes.get(indices)
        if scene is None:
            if len(self._scenes) >= SCENES_KEPT:  # a robot among thousands meets many sets
                self._scenes.clear()  # (the scene of every obstacle is kept in _full)
            scene = Scene([self.obstacles[i] for i in indices])
            self._scenes[indices] = scene
        return scene

    def _near(self, fp: Footprint, margin: float) -> tuple[int, ...]:
        """Obstacles whose bounding boxes come within ``margin`` of the footprint's capsule axes;
        any other obstacle is further than ``margin`` from every axis point."""
        if not self.obstacles:
            return ()
        everything = self._everything[0]
        ends = np.concatenate([fp.starts, fp.ends])
        lo, hi = ends.min(axis=0), ends.max(axis=0)
        return tuple(int(i) for i in everything.near(lo, hi, margin))

    def _near_point(self, point: Array, reach: float) -> tuple[int, ...]:
        """Obstacles whose bounding boxes come within ``reach`` of ``point`` (box distance)."""
        if not self.obstacles:
            return ()
        everything = self._everything[0]
        return tuple(int(i) for i in everything.near(point, point, reach))

    def contact(self, fp: Footprint) -> Contact | None:
        """The first obstacle or wall the footprint overlaps, or ``None`` when it is free."""
        ends = np.concatenate([fp.starts, fp.ends])
        wall = self.bounds.wall_clearance(ends) < np.concatenate([fp.radii, fp.radii])
        if np.any(wall):
            part = int(np.argmax(wall)) % len(fp.radii)
            return Contact(WALL, part, self._side(fp, part, self.bounds.wall_clearance))
        near = self._near(fp, float(np.max(fp.radii)))
        if near:
            hit = self._scene(near).segment_clearance(fp.starts, fp.ends) < fp.radii[:, None]
            touched = np.any(hit, axis=0)  # [obstacles near], in the obstacles' order
            if np.any(touched):
                column = int(np.argmax(touched))
                index, part = near[column], int(np.argmax(hit[:, column]))
                distance = _point_distance(self.obstacles[index])
                return Contact(index, part, self._side(fp, part, distance))
        return self._raster_contact(fp)

    def _raster_contact(self, fp: Footprint) -> Contact | None:
        """The first map whose occupied cells the footprint overlaps (after every obstacle)."""
        for k, raster in enumerate(self.rasters):
            gaps = raster.segment_gap(fp.starts, fp.ends, fp.radii, 1e-9)
            if np.any(gaps < 0):
                part = int(np.argmax(gaps < 0))

                def distance(points: Array, raster: OccupancyRaster = raster) -> Array:
                    p = np.atleast_2d(points)
                    return raster.point_distance(p).reshape(np.shape(points)[:-1])

                side = self._side(fp, part, distance)
                return Contact(len(self.obstacles) + k, part, side, f"map {k}")
        return None

    def _raster_gap(self, fp: Footprint, reach: float) -> float:
        """The smallest (capsule clearance - radius) to the maps' occupied cells, measured
        within ``reach`` (``reach`` when nothing is nearer)."""
        best = reach
        for raster in self.rasters:
            gaps = raster.segment_gap(fp.starts, fp.ends, fp.radii, reach)
            best = min(best, float(np.min(gaps)))
        return best

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
        corners, following = self._walls
        # Walls further than max_range (perpendicular distance) are left out the same way.
        b = self.bounds
        ox, oy = float(origin[0]), float(origin[1])
        reach = (oy - b.ymin, b.xmax - ox, b.ymax - oy, ox - b.xmin)  # the four edges in order
        close = [k for k in range(4) if not reach[k] > max_range]
        if collision_kernel.AVAILABLE and dirs.ndim == 2:
            return self._ray_cast_compiled(origin, dirs, max_range, close)
        if close:
            walls = ray_segment_hits(origin, dirs, corners[close], following[close]).min(axis=-1)
        else:
            walls = np.full(dirs.shape[0], np.inf)
        # Obstacles whose bounding boxes lie beyond max_range cannot change the capped answer:
        # they would be hit (if at all) beyond it, which reads as nothing within range.
        near = self._near_point(origin, max_range)
        if near:
            table = np.concatenate([walls[:, None], self._scene(near).ray_cast(origin, dirs)], -1)
        else:
            table = walls[:, None]  # [R, 1 + obstacles near]
        best = np.argmin(table, axis=-1)
        dist = table[np.arange(dirs.shape[0]), best]
        what = np.where(best == 0, WALL, np.asarray((WALL, *near))[best])
        dist, what = self._raster_rays(origin, dirs, max_range, dist, what)
        what = np.where(dist <= max_range, what, -2)
        return np.minimum(dist, max_range), what

    def _raster_rays(
        self, origin: Array, dirs: Array, max_range: float, dist: Array, what: Array
    ) -> tuple[Array, Array]:
        """Rays' first hits ``dist``/``what`` with the maps' occupied cells taken in: a map's
        cell strictly nearer than what the ray hit is what it hits (``len(obstacles) + k``)."""
        for k, raster in enumerate(self.rasters):
            t = raster.ray_cast(origin, dirs, max_range)
            closer = t < dist
            if np.any(closer):
                dist = np.where(closer, t, dist)
                what = np.where(closer, len(self.obstacles) + k, what)
        return dist, what

    def _ray_cast_compiled(
        self, origin: Array, dirs: Array, max_range: float, close: list[int]
    ) -> tuple[Array, Array]:
        """``ray_cast`` through the compiled kernel (circles' distances still from numpy)."""
        corners, following = self._walls
        near = self._near_point(origin, max_range)
        scene = self._scene(near)
        if scene.circle_index.size:
            circle_t = scene.circle_ray_cast(origin, dirs)
        else:
            circle_t = np.zeros((dirs.shape[0], 0))
        dist = np.empty(dirs.shape[0])
        what = np.empty(dirs.shape[0], dtype=np.int64)
        collision_kernel.ray_cast(
            np.asarray(origin, dtype=float),
            np.ascontiguousarray(dirs, dtype=float),
            float(max_range),
            corners[close],
            following[close],
            np.array(near, dtype=np.int64),
            scene.kind,
            circle_t,
            scene.edge_a,
            scene.edge_b,
            dist,
            what,
        )
        if self.rasters:
            # the kernel capped the distances: uncap the misses so a map's cell within range wins
            raw = np.where(what == -2, np.inf, dist)
            raw, found = self._raster_rays(origin, dirs, max_range, raw, cast(Array, what))
            found = np.where(raw <= max_range, found, -2)
            return np.minimum(raw, max_range), found
        return dist, cast(Array, what)  # integer indices, typed as ray_cast declares them

    def sensor_cast(
        self,
        origin: tuple[float, float],
        cos: Array,
        sin: Array,
        max_range: float,
        starts: NDArray[np.int64],
        caps: Array,
    ) -> tuple[Array, NDArray[np.int64]]:
        """Several sensors' readings at once, compiled (``collision_kernel.AVAILABLE``): rays
        of unit directions (``cos``, ``sin``) ``[R]`` from ``origin`` as ``ray_cast`` casts
        them, then per sensor ``k`` (rays ``starts[k]:starts[k + 1]``, range ``caps[k]``) the
        first of its rays with the smallest distance capped at its range, and what that ray
        hit (-2 beyond the range). Returns (distances ``[S]``, what ``[S]``)."""
        if self.rasters:
            return self._sensor_cast_rays(origin, cos, sin, max_range, starts, caps)
        ids, scene = self._candidates(origin, max_range)
        if scene.circle_index.size:
            dirs = np.empty((cos.size, 2))  # as ray_cast's callers stack them
            dirs[:, 0], dirs[:, 1] = cos, sin
            bq, rr = scene.circle_products(np.array(origin), dirs)
            circle_t = collision_kernel.circle_distances(bq, rr, scene.radii)
        else:
            circle_t = _NO_CIRCLES
        corners, following = self._walls
        value = np.empty(caps.size)
        what = np.empty(caps.size, dtype=np.int64)
        collision_kernel.sensor_cast(
            origin[0],
            origin[1],
            cos,
            sin,
            float(max_range),
            corners,
            following,
            ids,
            scene.kind,
            circle_t,
            scene.edge_a,
            scene.edge_b,
            starts,
            caps,
            value,
            what,
        )
        return value, what

    def _sensor_cast_rays(
        self,
        origin: tuple[float, float],
        cos: Array,
        sin: Array,
        max_range: float,
        starts: NDArray[np.int64],
        caps: Array,
    ) -> tuple[Array, NDArray[np.int64]]:
        """``sensor_cast`` with maps: every ray through ``ray_cast`` (which takes the maps'
        cells in), then per sensor the first of its rays with the smallest capped distance."""
        dirs = np.empty((cos.size, 2))
        dirs[:, 0], dirs[:, 1] = cos, sin
        dist, hits = self.ray_cast(np.array(origin), dirs, max_range)
        dists, whats = dist.tolist(), hits.tolist()
        value = np.empty(caps.size)
        what = np.empty(caps.size, dtype=np.int64)
        for k in range(caps.size):
            cap = float(caps[k])
            i = min(range(int(starts[k]), int(starts[k + 1])), key=lambda r: min(dists[r], cap))
            value[k] = min(dists[i], cap)
            what[k] = whats[i] if dists[i] <= cap else -2
        return value, what

    def _candidates(
        self, origin: tuple[float, float], reach: float
    ) -> tuple[NDArray[np.int64], Scene]:
        """The obstacles whose boxes come within ``reach`` + ``CANDIDATE_SLACK`` of a point
        at most ``CANDIDATE_SLACK`` (each axis) from ``origin``: a superset of those within
        ``reach`` of it, kept while the origin stays that close. Rays cast against a superset
        give the same capped answer (what lies beyond ``reach`` reads as nothing within it),
        so the set is recomputed only every few steps, not for every reading."""
        cached = self._near_cache.get(reach)
        if cached is not None:
            (ax, ay), ids, scene = cached
            if abs(origin[0] - ax) <= CANDIDATE_SLACK and abs(origin[1] - ay) <= CANDIDATE_SLACK:
                return ids, scene
        near = self._near_point(np.array(origin), reach + CANDIDATE_SLACK)
        ids, scene = np.array(near, dtype=np.int64), self._scene(near)
        self._near_cache[reach] = (origin, ids, scene)
        return ids, scene

    def gap(self, fp: Footprint) -> float:
        """Smallest gap between a footprint and any obstacle or wall (0 if touching)."""
        ends = np.concatenate([fp.starts, fp.ends])
        gap = float(np.min(self.bounds.wall_clearance(ends) - np.concatenate([fp.radii, fp.radii])))
        if self.obstacles:
            scene = self._everything[0]
            clearance = scene.segment_clearance(fp.starts, fp.ends) - fp.radii[:, None]
            gap = min(gap, float(np.min(clearance)))
        if self.rasters and gap > 0:  # map cells further than the gap so far cannot lower it
            gap = min(gap, self._raster_gap(fp, gap + 1e-9))
        return max(gap, 0.0)

    def free_within(self, fp: Footprint, distance: float) -> bool:
        """Whether ``distance <= gap(fp)``, measuring only obstacles that could decide it
        (those whose bounding boxes come within ``distance`` + the largest radius)."""
        if collision_kernel.AVAILABLE and fp.starts.ndim == 2:
            scene, box = self._everything
            margin = distance + max(fp.radii.tolist())
            if scene.index is None:
                ids = scene.all_ids
            else:
                ends = np.concatenate([fp.starts, fp.ends])
                ids = scene.candidate_ids(ends.min(axis=0), ends.max(axis=0), margin)
            gap: float = collision_kernel.gap(
                fp.starts,
                fp.ends,
                fp.radii,
                box,
                margin,
                ids,
                scene.boxes,
                scene.kind,
                scene.centres,
                scene.radii,
                scene.edge_a,
                scene.edge_b,
            )
            if self.rasters and gap >= distance:
                gap = min(gap, self._raster_gap(fp, distance + 1e-9))
            return distance <= max(gap, 0.0)
        ends = np.concatenate([fp.starts, fp.ends])
        gap = float(np.min(self.bounds.wall_clearance(ends) - np.concatenate([fp.radii, fp.radii])))
        near = self._near(fp, distance + float(np.max(fp.radii)))
        if near:
            clearance = self._scene(near).segment_clearance(fp.starts, fp.ends)
            gap = min(gap, float(np.min(clearance - fp.radii[:, None])))
        if self.rasters and gap >= distance:
            gap = min(gap, self._raster_gap(fp, distance + 1e-9))
        return distance <= max(gap, 0.0)

"""Obstacles (circles, rectangles, polygons): clearance to segments and ray casting.

All distances are Euclidean in metres. Each obstacle answers three questions, vectorised over
its argument: how far a set of segments is from it (0 when they touch or overlap), where rays
first hit it, and whether points lie inside it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from sim.robot import Array

EPS = 1e-12


def point_segment_distance(p: Array, a: Array, b: Array) -> Array:
    """Distance from points ``p`` to segments ``a-b`` (broadcast over leading axes)."""
    ab = b - a
    denom = np.maximum(np.sum(ab * ab, axis=-1), EPS)
    s = np.clip(np.sum((p - a) * ab, axis=-1) / denom, 0.0, 1.0)
    closest = a + s[..., None] * ab
    dist: Array = np.linalg.norm(p - closest, axis=-1)
    return dist


def _cross(u: Array, v: Array) -> Array:
    out: Array = u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]
    return out


def segments_intersect(a: Array, b: Array, c: Array, d: Array) -> Array:
    """Whether segments a-b and c-d cross or touch (broadcast)."""
    d1 = _cross(b - a, c - a)
    d2 = _cross(b - a, d - a)
    d3 = _cross(d - c, a - c)
    d4 = _cross(d - c, b - c)
    crossing = (d1 * d2 < 0) & (d3 * d4 < 0)
    return np.asarray(crossing)


def segment_segment_distance(a: Array, b: Array, c: Array, d: Array) -> Array:
    """Distance between segments a-b and c-d (0 where they cross), broadcast."""
    dist = np.minimum(
        np.minimum(point_segment_distance(a, c, d), point_segment_distance(b, c, d)),
        np.minimum(point_segment_distance(c, a, b), point_segment_distance(d, a, b)),
    )
    return np.where(segments_intersect(a, b, c, d), 0.0, dist)


def ray_segment_hits(origin: Array, dirs: Array, a: Array, b: Array) -> Array:
    """Distance along unit rays ``dirs`` ``[R, 2]`` to segments ``[E, 2]``; inf if missed. ``[R, E]``."""
    e = b - a  # [E, 2]
    denom = _cross(dirs[:, None, :], e[None, :, :])  # [R, E]
    rel = a[None, :, :] - origin  # [1, E, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = _cross(rel, e[None, :, :]) / denom
        s = _cross(rel, dirs[:, None, :]) / denom
    ok = (np.abs(denom) > EPS) & (t >= 0) & (s >= 0) & (s <= 1)
    return np.where(ok, t, np.inf)


@dataclass(frozen=True)
class Circle:
    x: float
    y: float
    radius: float
    name: str = ""
    known: bool = True

    def __post_init__(self) -> None:
        _check_finite("circle", (self.x, self.y, self.radius))
        if self.radius <= 0:
            raise ValueError("circle.radius: must be positive")

    @property
    def centre(self) -> Array:
        return np.array([self.x, self.y])

    def segment_clearance(self, a: Array, b: Array) -> Array:
        return np.maximum(point_segment_distance(self.centre, a, b) - self.radius, 0.0)

    def ray_cast(self, origin: Array, dirs: Array) -> Array:
        rel = origin - self.centre
        bq = dirs @ rel
        cq = rel @ rel - self.radius**2
        disc = bq * bq - cq
        root = np.sqrt(np.maximum(disc, 0.0))
        near, far = -bq - root, -bq + root
        t = np.where(near >= 0, near, np.where(far >= 0, 0.0, np.inf))  # inside: distance 0
        out: Array = np.where(disc >= 0, t, np.inf)
        return out

    def contains(self, points: Array) -> Array:
        return np.asarray(np.linalg.norm(points - self.centre, axis=-1) <= self.radius)

    def bounding_box(self) -> tuple[float, float, float, float]:
        r = self.radius
        return (self.x - r, self.y - r, self.x + r, self.y + r)

    def to_dict(self) -> dict[str, object]:
        return {
            "type": "circle",
            "x": self.x,
            "y": self.y,
            "radius": self.radius,
            "known": self.known,
        }


@dataclass(frozen=True)
class Polygon:
    """A simple polygon given by its vertices (either winding)."""

    points: tuple[tuple[float, float], ...]
    name: str = ""
    known: bool = True
    vertices: Array = field(init=False, repr=False, compare=False)
    _edges: tuple[Array, Array] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        pts = np.asarray(self.points, dtype=float)
        if pts.ndim != 2 or pts.shape[1] != 2 or pts.shape[0] < 3:
            raise ValueError("polygon.points: need at least 3 points [x, y]")
        if not np.all(np.isfinite(pts)):
            raise ValueError("polygon.points: values must be finite")
        if abs(_signed_area(pts)) < 1e-9:
            raise ValueError("polygon.points: the polygon has no area")
        object.__setattr__(self, "vertices", pts)
        object.__setattr__(self, "_edges", (pts, np.roll(pts, -1, axis=0)))

    @property
    def edges(self) -> tuple[Array, Array]:
        return self._edges

    def segment_clearance(self, a: Array, b: Array) -> Array:
        ea, eb = self.edges  # [E, 2]
        d = segment_segment_distance(a[..., None, :], b[..., None, :], ea, eb).min(axis=-1)
        inside = np.logical_or(self.contains(a), self.contains(b))
        return np.where(inside, 0.0, d)

    def ray_cast(self, origin: Array, dirs: Array) -> Array:
        if bool(self.contains(origin[None, :])[0]):
            return np.zeros(dirs.shape[0])
        ea, eb = self.edges
        hits: Array = ray_segment_hits(origin, dirs, ea, eb).min(axis=-1)
        return hits

    def contains(self, points: Array) -> Array:
        """Even-odd rule, vectorised over points ``[..., 2]``."""
        ea, eb = self.edges
        px, py = points[..., None, 0], points[..., None, 1]
        ax, ay, bx, by = ea[:, 0], ea[:, 1], eb[:, 0], eb[:, 1]
        straddle = (ay > py) != (by > py)
        with np.errstate(divide="ignore", invalid="ignore"):
            x_cross = ax + (py - ay) * (bx - ax) / (by - ay)
        crossings = np.sum(straddle & (px < x_cross), axis=-1)
        return np.asarray(crossings % 2 == 1)

    def bounding_box(self) -> tuple[float, float, float, float]:
        lo, hi = self.vertices.min(axis=0), self.vertices.max(axis=0)
        return (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))

    def to_dict(self) -> dict[str, object]:
        pts = [[float(x), float(y)] for x, y in self.vertices]
        return {"type": "polygon", "points": pts, "known": self.known}


def rectangle(
    x: float,
    y: float,
    width: float,
    height: float,
    angle: float = 0.0,
    name: str = "",
    known: bool = True,
) -> Polygon:
    """A rectangle centred at (x, y), ``width`` along its own x axis, rotated by ``angle``."""
    _check_finite("rectangle", (x, y, width, height, angle))
    if width <= 0 or height <= 0:
        raise ValueError("rectangle: width and height must be positive")
    c, s = math.cos(angle), math.sin(angle)
    corners = []
    for dx, dy in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
        lx, ly = dx * width / 2, dy * height / 2
        corners.append((x + c * lx - s * ly, y + s * lx + c * ly))
    return Polygon(tuple(corners), name=name, known=known)


Obstacle = Circle | Polygon


def obstacle_from_dict(data: dict[str, object]) -> Obstacle:
    """Build an obstacle from the API's JSON form (a mission's `obstacles`, docs/mission-format.md)."""
    kind = data.get("type")
    known = bool(data.get("known", True))
    name = str(data.get("name", ""))
    try:
        if kind == "circle":
            return Circle(_f(data["x"]), _f(data["y"]), _f(data["radius"]), name, known)
        if kind == "rectangle":
            return rectangle(
                _f(data["x"]),
                _f(data["y"]),
                _f(data["width"]),
                _f(data["height"]),
                _f(data.get("angle", 0.0)),
                name,
                known,
            )
        if kind == "polygon":
            raw = data["points"]
            if not isinstance(raw, list | tuple):
                raise ValueError("polygon.points: expected a list of [x, y]")
            pts = tuple((_f(p[0]), _f(p[1])) for p in raw)
            return Polygon(pts, name, known)
    except KeyError as exc:
        raise ValueError(f"{kind}: missing field {exc.args[0]!r}") from exc
    raise ValueError(f"obstacle type: expected circle, rectangle or polygon, got {kind!r}")


def _f(value: object) -> float:
    if not isinstance(value, int | float | str):
        raise ValueError(f"expected a number, got {value!r}")
    return float(value)


def _check_finite(kind: str, values: tuple[float, ...]) -> None:
    if not all(math.isfinite(v) for v in values):
        raise ValueError(f"{kind}: values must be finite")


def _signed_area(pts: Array) -> float:
    x, y = pts[:, 0], pts[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def unit_vectors(angles: ArrayLike) -> Array:
    a = np.asarray(angles, dtype=float)
    return np.stack([np.cos(a), np.sin(a)], axis=-1)

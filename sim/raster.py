"""Occupancy rasters: the one source of truth for "occupied" in a map of cells.

An ``OccupancyRaster`` is a map in ROS ``map_server``'s convention, already classified: cell
``(i, j)`` is the square ``origin + R(yaw) · ([i, i+1] × [j, j+1]) · resolution`` (``i`` along
the map's x, ``j`` along its y; the image's bottom row is ``j = 0``), and each cell is occupied,
free or unknown. The simulator collides with its occupied cells and casts rays against them by
raster lookup (``World``), and the planner's static layer reads the same cells
(``domain.world``): both see the same squares. Unknown cells are not obstacles to the simulator
(it must decide, and a map's unknown is "nobody looked"); the planner treats them as never
observed.

Geometry is done in the map's own frame, where the cells are axis-aligned squares: a world point
is translated by ``-origin`` and rotated by ``-yaw`` (distances are unchanged), so a non-zero yaw
costs nothing extra. Queries look only at the cells near what is asked (a box round the robot, a
ray's cells), never at the whole map.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from sim import collision_kernel
from sim.robot import Array

OCCUPIED, FREE, UNKNOWN = 1, 0, -1
OUTSIDE = -2  # what ``classes_at`` answers for points off the map
_EDGE = 1e-9  # squares that merely touch a cell's edge do not cover it


@dataclass(frozen=True)
class OccupancyRaster:
    """A classified occupancy map (``cells[i, j]``: ``OCCUPIED``, ``FREE`` or ``UNKNOWN``)."""

    cells: NDArray[np.int8]  # [nx, ny], i along the map's x, j along its y
    resolution: float  # metres per cell
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)  # the lower-left corner, and yaw
    name: str = ""
    _cos_sin: tuple[float, float] = field(init=False, repr=False, compare=False)
    _occupied: NDArray[np.bool_] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        cells = np.asarray(self.cells, dtype=np.int8)
        if cells.ndim != 2 or cells.size == 0:
            raise ValueError("raster.cells: need a non-empty 2-D array")
        if not (math.isfinite(self.resolution) and self.resolution > 0):
            raise ValueError("raster.resolution: must be positive and finite")
        if len(self.origin) != 3 or not all(math.isfinite(v) for v in self.origin):
            raise ValueError("raster.origin: need three finite numbers (x, y, yaw)")
        cells.flags.writeable = False
        object.__setattr__(self, "cells", cells)
        yaw = float(self.origin[2])
        object.__setattr__(self, "_cos_sin", (math.cos(yaw), math.sin(yaw)))
        occupied = cells == OCCUPIED
        occupied.flags.writeable = False
        object.__setattr__(self, "_occupied", occupied)

    # --- geometry -----------------------------------------------------------------------------

    @property
    def shape(self) -> tuple[int, int]:
        """``(nx, ny)``: cells along the map's x, along its y."""
        return (int(self.cells.shape[0]), int(self.cells.shape[1]))

    @property
    def occupied(self) -> NDArray[np.bool_]:
        """Which cells are occupied (read only)."""
        return self._occupied

    @property
    def rotated(self) -> bool:
        return self.origin[2] != 0.0

    def to_map(self, points: Array) -> Array:
        """World points ``[..., 2]`` in the map's frame (metres from the origin corner)."""
        c, s = self._cos_sin
        dx = points[..., 0] - self.origin[0]
        dy = points[..., 1] - self.origin[1]
        return np.stack([c * dx + s * dy, -s * dx + c * dy], axis=-1)

    def to_world(self, points: Array) -> Array:
        """Map-frame points ``[..., 2]`` in the world frame."""
        c, s = self._cos_sin
        u, v = points[..., 0], points[..., 1]
        return np.stack([self.origin[0] + c * u - s * v, self.origin[1] + s * u + c * v], axis=-1)

    def corners(self) -> Array:
        """The map's four corners in the world frame ``[4, 2]`` (counter-clockwise)."""
        nx, ny = self.shape
        w, h = nx * self.resolution, ny * self.resolution
        return self.to_world(np.array([[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]]))

    def extent(self) -> tuple[float, float, float, float]:
        """The world box ``(xmin, xmax, ymin, ymax)`` the map covers."""
        c = self.corners()
        lo, hi = c.min(axis=0), c.max(axis=0)
        return (float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1]))

    def cell_centres(self, i: NDArray[np.intp], j: NDArray[np.intp]) -> Array:
        """World centres ``[N, 2]`` of cells ``(i, j)``: origin + R(yaw)·(i + ½, j + ½)·resolution."""
        local = np.stack([(i + 0.5) * self.resolution, (j + 0.5) * self.resolution], axis=-1)
        return self.to_world(local)

    # --- lookups ------------------------------------------------------------------------------

    def classes_at(self, points: Array) -> NDArray[np.int8]:
        """The class of the cell holding each world point ``[..., 2]`` (``OUTSIDE`` off the map)."""
        local = self.to_map(np.asarray(points, dtype=float))
        i = np.floor(local[..., 0] / self.resolution)
        j = np.floor(local[..., 1] / self.resolution)
        nx, ny = self.shape
        inside = (i >= 0) & (i < nx) & (j >= 0) & (j < ny)
        out = np.full(i.shape, OUTSIDE, dtype=np.int8)
        out[inside] = self.cells[i[inside].astype(np.intp), j[inside].astype(np.intp)]
        return out

    def occupied_at(self, points: Array) -> NDArray[np.bool_]:
        """Whether each world point ``[..., 2]`` lies in an occupied cell."""
        out: NDArray[np.bool_] = self.classes_at(points) == OCCUPIED
        return out

    def counts(self) -> dict[str, int]:
        """How many cells are occupied, free, unknown."""
        return {
            "occupied": int(np.count_nonzero(self.cells == OCCUPIED)),
            "free": int(np.count_nonzero(self.cells == FREE)),
            "unknown": int(np.count_nonzero(self.cells == UNKNOWN)),
        }

    def _window(self, lo: Array, hi: Array) -> tuple[int, int, int, int]:
        """Cells ``i0:i1, j0:j1`` a map-frame box ``lo``-``hi`` overlaps, clipped to the map."""
        r = self.resolution
        nx, ny = self.shape
        i0 = max(0, math.floor(lo[0] / r))
        i1 = min(nx, math.floor(hi[0] / r) + 1)
        j0 = max(0, math.floor(lo[1] / r))
        j1 = min(ny, math.floor(hi[1] / r) + 1)
        return i0, i1, j0, j1

    def occupied_near(self, lo: Array, hi: Array) -> tuple[Array, Array]:
        """The occupied cells whose squares a map-frame box ``lo``-``hi`` overlaps, as their
        squares' lower corners and upper corners ``[N, 2]`` (map frame)."""
        i0, i1, j0, j1 = self._window(lo, hi)
        if i0 >= i1 or j0 >= j1:
            empty = np.zeros((0, 2))
            return empty, empty
        ii, jj = np.nonzero(self._occupied[i0:i1, j0:j1])
        r = self.resolution
        low = np.stack([(ii + i0) * r, (jj + j0) * r], axis=-1).astype(float)
        return low, low + r

    # --- distances (the simulator's collisions) -----------------------------------------------

    def segment_gap(self, starts: Array, ends: Array, radii: Array, reach: float) -> Array:
        """Per capsule (axis ``starts[c]-ends[c]``, radius ``radii[c]``): the distance from its
        axis to the nearest occupied cell's square less its radius, looking only at cells
        within ``reach`` + radius of the axis (``reach`` where there are none). ``[C]``.
        Compiled (``collision_kernel.raster_gaps``) when the kernels are, else numpy: the
        same distances."""
        starts = np.ascontiguousarray(starts, dtype=float).reshape(-1, 2)
        ends = np.ascontiguousarray(ends, dtype=float).reshape(-1, 2)
        radii = np.ascontiguousarray(radii, dtype=float).reshape(-1)
        out = np.empty(starts.shape[0])
        if collision_kernel.AVAILABLE:
            c, s = self._cos_sin
            frame = np.array([self.origin[0], self.origin[1], c, s])
            collision_kernel.raster_gaps(
                starts, ends, radii, float(reach), self._occupied, self.resolution, frame, out
            )
            return out
        a, b = self.to_map(starts), self.to_map(ends)
        grow = reach + float(np.max(radii))
        low, high = self.occupied_near(
            np.minimum(a, b).min(axis=0) - grow, np.maximum(a, b).max(axis=0) + grow
        )
        for c in range(a.shape[0]):
            if not low.shape[0]:
                out[c] = reach
                continue
            d = float(np.min(segment_box_distance(a[c], b[c], low, high)))
            out[c] = min(d - float(radii[c]), reach)
        return out

    def point_distance(self, points: Array, reach: float = 1.0) -> Array:
        """Distance from world points ``[N, 2]`` to the nearest occupied square (at most
        ``reach``): the field a contact's side is read from."""
        p = np.atleast_2d(np.asarray(points, dtype=float))
        return self.segment_gap(p, p, np.zeros(p.shape[0]), reach)

    # --- rays (the simulator's sensors) -------------------------------------------------------

    def ray_cast(self, origin: Array, dirs: Array, max_range: float) -> Array:
        """Distance along unit rays ``dirs`` ``[R, 2]`` from ``origin`` to the first occupied
        cell they enter (0 when the origin's cell is occupied), inf when none within
        ``max_range``. Exact: every cell boundary a ray crosses within range is visited (all
        rays at once: the crossings of the map's vertical and horizontal lines, sorted)."""
        o = self.to_map(np.asarray(origin, dtype=float)[None, :])[0]
        c, s = self._cos_sin
        d = np.stack([c * dirs[:, 0] + s * dirs[:, 1], -s * dirs[:, 0] + c * dirs[:, 1]], axis=-1)
        r = self.resolution
        # A box round the rays' reach that misses every occupied cell: nothing to hit.
        lo, hi = o - max_range, o + max_range
        i0, i1, j0, j1 = self._window(lo, hi)
        if i0 >= i1 or j0 >= j1 or not self._occupied[i0:i1, j0:j1].any():
            return np.full(dirs.shape[0], np.inf)
        n = math.ceil(max_range / r) + 2
        k = np.arange(-n, n + 1, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            tx = ((math.floor(o[0] / r) + k)[None, :] * r - o[0]) / d[:, :1]  # [R, 2n+1]
            ty = ((math.floor(o[1] / r) + k)[None, :] * r - o[1]) / d[:, 1:]
        t = np.concatenate([np.zeros((dirs.shape[0], 1)), tx, ty], axis=1)
        t = np.where(np.isfinite(t) & (t >= 0) & (t <= max_range), t, np.inf)
        t.sort(axis=1)
        # The cell each stretch between crossings lies in, read at its middle.
        after = np.concatenate([t[:, 1:], np.full((t.shape[0], 1), np.inf)], axis=1)
        end = np.minimum(after, max_range)
        mid = np.where(np.isfinite(t), 0.5 * (t + end), 0.0)
        px = o[0] + mid * d[:, :1]
        py = o[1] + mid * d[:, 1:]
        i = np.floor(px / r)
        j = np.floor(py / r)
        nx, ny = self.shape
        inside = np.isfinite(t) & (i >= 0) & (i < nx) & (j >= 0) & (j < ny)
        hit = np.zeros(t.shape, dtype=bool)
        hit[inside] = self._occupied[i[inside].astype(np.intp), j[inside].astype(np.intp)]
        first = np.argmax(hit, axis=1)
        found = hit[np.arange(t.shape[0]), first]
        return np.where(found, t[np.arange(t.shape[0]), first], np.inf)

    # --- onto another grid (the planner's static layer) ---------------------------------------

    def cover(
        self, origin: tuple[float, float], resolution: float, shape: tuple[int, int], which: int
    ) -> NDArray[np.bool_]:
        """Cells of an axis-aligned grid (``origin``, ``resolution``, ``shape``) that any cell of
        class ``which`` overlaps (by the square's world box when the map is rotated: a
        superset), so that nothing the map holds falls between the grid's cells."""
        nx, ny = shape
        out = np.zeros(shape, dtype=bool)
        ii, jj = np.nonzero(self.cells == which)
        if not ii.size:
            return out
        r = self.resolution
        if self.rotated:
            quad = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float) * r
            local = np.stack([ii * r, jj * r], axis=-1).astype(float)
            world = self.to_world(local[:, None, :] + quad[None, :, :])  # [N, 4, 2]
            lo, hi = world.min(axis=1), world.max(axis=1)
        else:
            lo = np.stack([ii * r + self.origin[0], jj * r + self.origin[1]], axis=-1)
            hi = lo + r
        g0 = np.array(origin, dtype=float)
        first = np.floor((lo - g0) / resolution + _EDGE).astype(np.intp)
        last = np.ceil((hi - g0) / resolution - _EDGE).astype(np.intp)  # exclusive
        first = np.maximum(first, 0)
        last = np.minimum(last, np.array([nx, ny]))
        span = last - first
        keep = (span[:, 0] > 0) & (span[:, 1] > 0)
        first, span = first[keep], span[keep]
        if not first.shape[0]:
            return out
        for di in range(int(span[:, 0].max())):
            for dj in range(int(span[:, 1].max())):
                sel = (span[:, 0] > di) & (span[:, 1] > dj)
                out[first[sel, 0] + di, first[sel, 1] + dj] = True
        return out

    def sample(
        self, origin: tuple[float, float], resolution: float, shape: tuple[int, int]
    ) -> NDArray[np.int8]:
        """The class at each centre of an axis-aligned grid (``OUTSIDE`` off the map)."""
        nx, ny = shape
        xs = origin[0] + (np.arange(nx) + 0.5) * resolution
        ys = origin[1] + (np.arange(ny) + 0.5) * resolution
        x, y = np.meshgrid(xs, ys, indexing="ij")
        return self.classes_at(np.stack([x, y], axis=-1))


def segment_box_distance(a: Array, b: Array, low: Array, high: Array) -> Array:
    """Distance from the segment ``a-b`` (``[2]``) to each axis-aligned box ``low``-``high``
    ``[N, 2]`` (0 where they overlap). Two convex sets apart are nearest at a vertex of one
    against the other: the segment's ends against the boxes, the boxes' corners against the
    segment; they overlap where the segment (clipped by slabs) meets the box."""

    # ends against boxes
    def point_box(p: Array) -> Array:
        gap = np.maximum(np.maximum(low - p, p - high), 0.0)
        out: Array = np.hypot(gap[:, 0], gap[:, 1])
        return out

    best = np.minimum(point_box(a), point_box(b))
    # corners against the segment
    ab = b - a
    denom = max(float(ab @ ab), 1e-24)
    for cx, cy in (
        (low[:, 0], low[:, 1]),
        (high[:, 0], low[:, 1]),
        (high[:, 0], high[:, 1]),
        (low[:, 0], high[:, 1]),
    ):
        s = np.clip(((cx - a[0]) * ab[0] + (cy - a[1]) * ab[1]) / denom, 0.0, 1.0)
        best = np.minimum(best, np.hypot(cx - (a[0] + s * ab[0]), cy - (a[1] + s * ab[1])))
    # overlap: the segment's parameter interval inside both slabs is not empty
    t0 = np.zeros(low.shape[0])
    t1 = np.ones(low.shape[0])
    for axis in (0, 1):
        if abs(float(ab[axis])) < 1e-15:
            outside = (a[axis] < low[:, axis]) | (a[axis] > high[:, axis])
            t1 = np.where(outside, -1.0, t1)
            continue
        u = (low[:, axis] - a[axis]) / ab[axis]
        v = (high[:, axis] - a[axis]) / ab[axis]
        t0 = np.maximum(t0, np.minimum(u, v))
        t1 = np.minimum(t1, np.maximum(u, v))
    out: Array = np.where(t0 <= t1, 0.0, best)
    return out


def warm() -> None:
    """Load the compiled raster kernel (numba's disk cache; compiled on a first run ever), so
    that a process's first map pays nothing for it."""
    raster = OccupancyRaster(np.array([[OCCUPIED, FREE]], dtype=np.int8), 0.05)
    point = np.zeros((1, 2))
    raster.segment_gap(point, point, np.zeros(1), 0.1)

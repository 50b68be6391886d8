"""A compiled (numba) footprint gap: the simulator's per-step "is the way free?" in one loop.

``World.free_within`` asks every step how far the body's five capsules are from the walls and
the obstacles near them; in numpy that is a few dozen calls on 2-10-element arrays. ``gap``
answers in one compiled loop with the same arithmetic, element by element, as
``sim.obstacles`` (``point_segment_distance``, ``segments_intersect``, the even-odd
``contains``) and ``Scene.segment_clearance``, so its answer equals the numpy one value for
value (no fast-math: no fused multiply-adds; minima are exact in any order).
``tests/sim/test_scene.py`` holds ``free_within`` to the obstacle-by-obstacle reference.

Without numba (or with ``SCREWSNAKE_KERNELS=numpy``) ``AVAILABLE`` is False and ``World`` keeps
its numpy path.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sim.kernel_setting import kernel_setting
from sim.robot import Array

try:  # numba is a dependency, but the numpy path must keep working without it
    import numba
except ImportError:  # pragma: no cover - exercised by installs without numba
    numba = None  # type: ignore[assignment]

AVAILABLE = numba is not None and kernel_setting() != "numpy"
EPS = 1e-12  # as sim.obstacles.EPS


def _jit(fn: Any) -> Any:
    """Compile ``fn`` with numba (cached on disk) when it is available, else leave it Python."""
    if numba is None:  # pragma: no cover
        return fn
    return numba.njit(cache=True, nogil=True)(fn)


@_jit
def _point_segment(
    px: float, py: float, ax: float, ay: float, bx: float, by: float
) -> float:  # pragma: no cover - compiled
    """``point_segment_distance`` for one point and one segment, in its operation order."""
    abx, aby = bx - ax, by - ay
    denom = max(abx * abx + aby * aby, EPS)
    s = ((px - ax) * abx + (py - ay) * aby) / denom
    s = min(max(s, 0.0), 1.0)
    dx, dy = px - (ax + s * abx), py - (ay + s * aby)
    return float(math.sqrt(dx * dx + dy * dy))


@_jit
def _inside(
    px: float, py: float, ea: Array, eb: Array, lo: int, hi: int
) -> bool:  # pragma: no cover
    """Whether (px, py) lies inside the polygon of edges ``lo:hi`` (even-odd rule)."""
    crossings = 0
    for e in range(lo, hi):
        ax, ay, bx, by = ea[e, 0], ea[e, 1], eb[e, 0], eb[e, 1]
        if (ay > py) != (by > py):
            x_cross = ax + (py - ay) * (bx - ax) / (by - ay)
            if px < x_cross:
                crossings += 1
    return crossings % 2 == 1


@_jit
def _segment_edge(
    ax: float, ay: float, bx: float, by: float, cx: float, cy: float, dx: float, dy: float
) -> float:  # pragma: no cover - compiled
    """``segment_segment_distance`` of a-b and c-d (0 where they cross)."""
    d1 = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    d2 = (bx - ax) * (dy - ay) - (by - ay) * (dx - ax)
    d3 = (dx - cx) * (ay - cy) - (dy - cy) * (ax - cx)
    d4 = (dx - cx) * (by - cy) - (dy - cy) * (bx - cx)
    if d1 * d2 < 0 and d3 * d4 < 0:
        return 0.0
    to_edge = min(_point_segment(ax, ay, cx, cy, dx, dy), _point_segment(bx, by, cx, cy, dx, dy))
    to_segment = min(_point_segment(cx, cy, ax, ay, bx, by), _point_segment(dx, dy, ax, ay, bx, by))
    return float(min(to_edge, to_segment))


@_jit
def gap(  # pragma: no cover - compiled
    starts: Array,  # [C, 2] capsule axes
    ends: Array,
    radii: Array,  # [C]
    bounds: Array,  # (xmin, xmax, ymin, ymax)
    margin: float,  # obstacles whose boxes lie further than this from the axes are left out
    ids: NDArray[np.int64],  # the obstacles to look at (a superset of those near: an index's)
    boxes: Array,  # [N, 4] (x0, y0, x1, y1)
    kind: NDArray[np.int64],  # [N, 3]: circle row or -1, first edge, edges (polygons)
    centres: Array,
    circle_radii: Array,
    edge_a: Array,
    edge_b: Array,
) -> float:
    """The smallest (capsule clearance - radius) over the walls and the obstacles whose boxes
    come within ``margin`` of the capsule axes' box (may be negative)."""
    xmin, xmax, ymin, ymax = bounds[0], bounds[1], bounds[2], bounds[3]
    n = starts.shape[0]
    best = np.inf
    lox, loy, hix, hiy = np.inf, np.inf, -np.inf, -np.inf
    for c in range(n):
        for p in (starts[c], ends[c]):
            x, y = p[0], p[1]
            wall = min(min(x - xmin, xmax - x), min(y - ymin, ymax - y))
            best = min(best, wall - radii[c])
            lox, loy, hix, hiy = min(lox, x), min(loy, y), max(hix, x), max(hiy, y)
    for o in ids:
        b = boxes[o]
        if not (
            b[0] <= hix + margin
            and b[2] >= lox - margin
            and b[1] <= hiy + margin
            and b[3] >= loy - margin
        ):
            continue
        k = kind[o, 0]
        for c in range(n):
            ax, ay, bx, by = starts[c, 0], starts[c, 1], ends[c, 0], ends[c, 1]
            if k >= 0:
                near = _point_segment(centres[k, 0], centres[k, 1], ax, ay, bx, by)
                clearance = max(near - circle_radii[k], 0.0)
            else:
                lo, hi = kind[o, 1], kind[o, 1] + kind[o, 2]
                if _inside(ax, ay, edge_a, edge_b, lo, hi) or _inside(
                    bx, by, edge_a, edge_b, lo, hi
                ):
                    clearance = 0.0
                else:
                    clearance = np.inf
                    for e in range(lo, hi):
                        d = _segment_edge(
                            ax, ay, bx, by, edge_a[e, 0], edge_a[e, 1], edge_b[e, 0], edge_b[e, 1]
                        )
                        clearance = min(clearance, d)
            best = min(best, clearance - radii[c])
    return float(best)


@_jit
def _ray_edge(
    ox: float, oy: float, dx: float, dy: float, ax: float, ay: float, bx: float, by: float
) -> float:  # pragma: no cover - compiled
    """``ray_segment_hits`` for one unit ray and one segment: the distance along it, inf if missed."""
    ex, ey = bx - ax, by - ay
    denom = dx * ey - dy * ex
    if not abs(denom) > EPS:
        return np.inf
    rx, ry = ax - ox, ay - oy
    t = (rx * ey - ry * ex) / denom
    s = (rx * dy - ry * dx) / denom
    if t >= 0 and s >= 0 and s <= 1:
        return t
    return np.inf


@_jit
def _first_hit(
    ox: float,
    oy: float,
    dx: float,
    dy: float,
    r: int,
    wall_a: Array,
    wall_b: Array,
    ids: NDArray[np.int64],
    kind: NDArray[np.int64],
    inside: NDArray[np.bool_],
    circle_t: Array,
    edge_a: Array,
    edge_b: Array,
) -> tuple[float, int]:  # pragma: no cover - compiled
    """Ray ``r`` (unit direction dx, dy): the distance to the first hit and what it hit (the
    walls first, then each obstacle in order; the first strict minimum wins)."""
    best = np.inf
    for w in range(wall_a.shape[0]):
        best = min(
            best,
            _ray_edge(ox, oy, dx, dy, wall_a[w, 0], wall_a[w, 1], wall_b[w, 0], wall_b[w, 1]),
        )
    hit = -1
    for j in range(ids.size):
        if kind[j, 0] >= 0:
            t = circle_t[r, kind[j, 0]]
        elif inside[j]:
            t = 0.0
        else:
            t = np.inf
            for e in range(kind[j, 1], kind[j, 1] + kind[j, 2]):
                t = min(
                    t,
                    _ray_edge(
                        ox, oy, dx, dy, edge_a[e, 0], edge_a[e, 1], edge_b[e, 0], edge_b[e, 1]
                    ),
                )
        if t < best:
            best, hit = t, ids[j]
    return best, hit


@_jit
def _origin_inside(
    ox: float, oy: float, kind: NDArray[np.int64], edge_a: Array, edge_b: Array
) -> NDArray[np.bool_]:  # pragma: no cover - compiled
    """Per obstacle of a scene: whether the origin lies inside it (polygons only)."""
    inside = np.zeros(kind.shape[0], dtype=np.bool_)
    for j in range(kind.shape[0]):
        if kind[j, 0] < 0:
            inside[j] = _inside(ox, oy, edge_a, edge_b, kind[j, 1], kind[j, 1] + kind[j, 2])
    return inside


@_jit
def ray_cast(  # pragma: no cover - compiled
    origin: Array,
    dirs: Array,  # [R, 2] unit rays
    max_range: float,
    wall_a: Array,  # [W, 2] the arena edges within reach
    wall_b: Array,
    ids: NDArray[np.int64],  # [M] the obstacles near enough to matter, in index order
    kind: NDArray[np.int64],  # [M, 3] of their scene (circle column or -1, first edge, edges)
    circle_t: Array,  # [R, circles of the scene]: their distances, from numpy (see World)
    edge_a: Array,
    edge_b: Array,
    dist: Array,  # out [R]
    what: NDArray[np.int64],  # out [R]: obstacle index, -1 (wall) or -2 (nothing in range)
) -> None:
    """``World.ray_cast``'s first hits: the walls first, then each obstacle in order, the
    first strict minimum wins (as ``argmin`` over its table); capped at ``max_range``."""
    ox, oy = origin[0], origin[1]
    inside = _origin_inside(ox, oy, kind, edge_a, edge_b)
    for r in range(dirs.shape[0]):
        best, hit = _first_hit(
            ox,
            oy,
            dirs[r, 0],
            dirs[r, 1],
            r,
            wall_a,
            wall_b,
            ids,
            kind,
            inside,
            circle_t,
            edge_a,
            edge_b,
        )
        what[r] = hit if best <= max_range else -2
        dist[r] = min(best, max_range)


@_jit
def sensor_cast(  # pragma: no cover - compiled
    ox: float,
    oy: float,
    cos: Array,  # [R] the rays' unit directions, x ...
    sin: Array,  # ... and y
    max_range: float,
    wall_a: Array,
    wall_b: Array,
    ids: NDArray[np.int64],
    kind: NDArray[np.int64],
    circle_t: Array,  # [R, circles]: distances, see circle_distances
    edge_a: Array,
    edge_b: Array,
    starts: NDArray[np.int64],  # [S + 1]: sensor k's rays are starts[k]:starts[k + 1]
    caps: Array,  # [S]: each sensor's own range
    value: Array,  # out [S]: each sensor's nearest reading, capped at its range
    what: NDArray[np.int64],  # out [S]: what that ray hit, -2 when nothing within the range
) -> None:
    """``ray_cast`` for the rays of several sensors, then per sensor the first of its rays
    with the smallest capped distance (as ``min`` over them with that key). ``circle_t``
    holds the circles' ray products from numpy (``circle_distances`` turns them into
    distances first)."""
    inside = _origin_inside(ox, oy, kind, edge_a, edge_b)
    dist = np.empty(cos.size)
    hits = np.empty(cos.size, dtype=np.int64)
    for r in range(cos.size):
        best, hit = _first_hit(
            ox, oy, cos[r], sin[r], r, wall_a, wall_b, ids, kind, inside, circle_t, edge_a, edge_b
        )
        hits[r] = hit if best <= max_range else -2
        dist[r] = min(best, max_range)
    for k in range(caps.size):
        cap = caps[k]
        i = starts[k]
        v = min(dist[i], cap)
        for m in range(starts[k] + 1, starts[k + 1]):
            if min(dist[m], cap) < v:
                i, v = m, min(dist[m], cap)
        value[k] = v
        what[k] = hits[i] if dist[i] <= cap else -2


@_jit
def circle_distances(bq: Array, rr: Array, radii: Array) -> Array:  # pragma: no cover - compiled
    """``Scene.circle_ray_cast`` from its products (numpy's, BLAS may fuse them): per circle
    ``c`` and ray ``r``, ``bq[c, r]`` = dirs[r] · rel[c] and ``rr[c]`` = rel[c] · rel[c]
    (rel = origin - centre); the rest element by element as numpy computes it. ``[R, C]``."""
    n_c, n_r = bq.shape[0], bq.shape[1]
    out = np.empty((n_r, n_c))
    for c in range(n_c):
        cq = rr[c] - radii[c] * radii[c]
        for r in range(n_r):
            b = bq[c, r]
            disc = b * b - cq
            root = math.sqrt(max(disc, 0.0))
            near, far = -b - root, -b + root
            t = near if near >= 0 else (0.0 if far >= 0 else np.inf)
            out[r, c] = t if disc >= 0 else np.inf
    return out


@_jit
def raster_gaps(  # pragma: no cover - compiled
    starts: Array,  # [C, 2] capsule axes, world frame
    ends: Array,
    radii: Array,  # [C]
    reach: float,  # cells further than this (+ the radius) from an axis are not measured
    occupied: NDArray[np.bool_],  # [nx, ny] the map's occupied cells
    resolution: float,
    frame: Array,  # (origin x, origin y, cos yaw, sin yaw)
    out: Array,  # out [C]: per capsule, min(distance to an occupied square - radius, reach)
) -> None:
    """``OccupancyRaster.segment_gap`` in one loop: each capsule's axis in the map's frame
    against the occupied squares of its window (the axis' box grown by reach + radius). A
    segment and a square are 0 apart when an end lies in the square or the segment crosses
    one of its edges; else the nearest pair is an end against an edge or a corner against the
    segment: ``_segment_edge`` over the four edges covers both."""
    ox, oy, c, s = frame[0], frame[1], frame[2], frame[3]
    nx, ny = occupied.shape
    for k in range(starts.shape[0]):
        dx, dy = starts[k, 0] - ox, starts[k, 1] - oy
        ax, ay = c * dx + s * dy, -s * dx + c * dy
        dx, dy = ends[k, 0] - ox, ends[k, 1] - oy
        bx, by = c * dx + s * dy, -s * dx + c * dy
        grow = reach + radii[k]
        i0 = max(0, int(math.floor((min(ax, bx) - grow) / resolution)))
        i1 = min(nx, int(math.floor((max(ax, bx) + grow) / resolution)) + 1)
        j0 = max(0, int(math.floor((min(ay, by) - grow) / resolution)))
        j1 = min(ny, int(math.floor((max(ay, by) + grow) / resolution)) + 1)
        best = reach
        for i in range(i0, i1):
            x0 = i * resolution
            x1 = x0 + resolution
            for j in range(j0, j1):
                if not occupied[i, j]:
                    continue
                y0 = j * resolution
                y1 = y0 + resolution
                if (x0 <= ax <= x1 and y0 <= ay <= y1) or (x0 <= bx <= x1 and y0 <= by <= y1):
                    d = 0.0
                else:
                    d = min(
                        min(
                            _segment_edge(ax, ay, bx, by, x0, y0, x1, y0),
                            _segment_edge(ax, ay, bx, by, x1, y0, x1, y1),
                        ),
                        min(
                            _segment_edge(ax, ay, bx, by, x1, y1, x0, y1),
                            _segment_edge(ax, ay, bx, by, x0, y1, x0, y0),
                        ),
                    )
                best = min(best, d - radii[k])
        out[k] = best

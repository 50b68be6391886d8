"""Whether a mission's straight body can reach its goals at all, with every obstacle known: a
configuration-space flood fill, independent of the planner (sim/ geometry, numpy and scipy).

A configuration is the body centroid (x, y) on a grid of ``resolution`` metres and the heading
ψ, one of ``headings`` steps. It is free where every capsule of ``sim.world.footprint`` (the
head and four units of the straight body) keeps ``margin`` from every obstacle and the arena's
walls. Free configurations that are grid neighbours (26 of them, ψ wrapping round) are joined;
a goal is reachable when a free configuration joined to the start puts the tracked point
within ``GOAL_FRACTION`` of its tolerance (at least ``GOAL_MIN``), as the planner's lattice
counts a goal.

Clearance is exact (the obstacles' own distances) at the points of a ``RASTER`` grid, and each
capsule's axis is sampled every ``AXIS_STEP``. A sample rounded to the raster is at most
``RASTER``/√2 from where it should be, and a distance changes by no more than the point moved,
so the test adds that error (and the axis sampling's) to the margin when it must be sure
(``sure=True``: "reachable" then holds with the margin to spare) and subtracts it when it must
not miss a way (``sure=False``). ``verdict`` asks both: feasible for sure at ``MARGIN``,
infeasible even optimistically at margin 0, and borderline in between. One grid step moves a
body point at most ~6 cm; a unit that keeps 1 cm from a point at both ends of such a move
passes it with 0.45 cm to spare (√(0.085² − 0.03²) − 0.075), and from a flat face it cannot
dip at all, so at ``MARGIN`` the fill's joins are collision-free motions in practice (checked
along one path found through a bent slot), not a proof.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from sim.obstacles import Circle, Obstacle, obstacle_from_dict
from sim.robot import DEFAULT_GEOMETRY, Array, centroid
from sim.world import Bounds, footprint

MARGIN = 0.01  # m of clearance a feasible world keeps (the planner keeps 0.02)
GOAL_FRACTION = 0.6  # of a goal's tolerance: how near the tracked point counts
GOAL_MIN = 0.03  # m: the nearest the planner's goal test ever asks for
RASTER = 0.005  # m between the points where clearance is computed exactly
AXIS_STEP = 0.0125  # m between the samples along a capsule's axis
RESOLUTION = 0.025  # m between the configurations' centroids
HEADINGS = 128  # heading steps of 2.8°
TILE = 100  # raster points per side of the tiles one obstacle's distances are computed in
STRAIGHT = np.zeros(3)

Mask = NDArray[np.bool_]


@dataclass(frozen=True)
class Feasibility:
    """One flood fill's answer."""

    reachable: bool  # every goal, in the start's component
    goals: tuple[bool, ...]  # each goal reachable from the start
    start_free: bool  # some configuration next to the start is free
    margin: float
    sure: bool  # errors added to the margin (True) or subtracted from it
    free_fraction: float  # of all configurations
    seconds: float


@dataclass(frozen=True)
class Verdict:
    """What a generated world is: feasible, infeasible, or borderline (feasible at margin 0
    only, or not certainly at ``MARGIN``)."""

    feasible: bool  # for sure, at MARGIN
    borderline: bool  # not feasible for sure, but not infeasible at margin 0 either
    seconds: float

    @property
    def label(self) -> str:
        if self.feasible:
            return "feasible"
        return "borderline" if self.borderline else "infeasible"


def verdict(mission: Mapping[str, Any], **grid: Any) -> Verdict:
    """Feasible for sure at ``MARGIN``; if not, whether it is infeasible even at margin 0
    with the raster's error in the body's favour (else borderline)."""
    t0 = time.perf_counter()
    sure = check(mission, MARGIN, sure=True, **grid)
    if sure.reachable:
        return Verdict(True, False, time.perf_counter() - t0)
    loose = check(mission, 0.0, sure=False, **grid)
    return Verdict(False, loose.reachable, time.perf_counter() - t0)


def check(
    mission: Mapping[str, Any],
    margin: float = MARGIN,
    sure: bool = True,
    resolution: float = RESOLUTION,
    headings: int = HEADINGS,
) -> Feasibility:
    """The flood fill for a mission in its JSON form (the straight body only)."""
    t0 = time.perf_counter()
    if _shape(mission) != "straight":
        raise ValueError("feasibility: only the straight body is checked")
    b = mission.get("bounds", {})
    bounds = Bounds(
        float(b.get("xmin", -10.0)),
        float(b.get("xmax", 10.0)),
        float(b.get("ymin", -10.0)),
        float(b.get("ymax", 10.0)),
    )
    obstacles = [obstacle_from_dict(dict(o)) for o in mission.get("obstacles", [])]
    factor = round(resolution / RASTER)
    if factor < 1 or not math.isclose(factor * RASTER, resolution):
        raise ValueError(f"resolution: a multiple of {RASTER} m")
    g = DEFAULT_GEOMETRY
    radii = (g.head_radius, g.unit_radius)
    # Thresholds are binned to 0.25 mm (rounded the safe way) so a few masks serve all samples.
    cap = g.unit_radius + margin + RASTER + 0.002
    clearance = clearance_raster(bounds, obstacles, cap)
    offsets, kinds, slack = _samples(headings)
    sign = 1.0 if sure else -1.0
    pad = int(np.max(np.abs(offsets))) + 1
    nu = int((bounds.xmax - bounds.xmin) / resolution) + 1
    nv = int((bounds.ymax - bounds.ymin) / resolution) + 1
    # Per binned threshold, the padded mask split by raster phase: a sample's column of the
    # configuration grid is then one contiguous slice (strided reads were 3x slower).
    phases: dict[tuple[int, int], list[list[Mask]]] = {}

    def mask(kind: int, need: float) -> list[list[Mask]]:
        key = (kind, math.ceil(need / 0.00025) if sure else int(need // 0.00025))
        got = phases.get(key)
        if got is None:
            full = np.pad(clearance >= key[1] * 0.00025, pad, constant_values=False)
            got = [
                [np.ascontiguousarray(full[a::factor, b::factor]) for b in range(factor)]
                for a in range(factor)
            ]
            phases[key] = got
        return got

    free = np.zeros((nu, nv, headings + 1), dtype=bool)
    for k in range(headings):
        ok = np.ones((nu, nv), dtype=bool)
        for (ox, oy), kind, err in zip(offsets[k], kinds, slack[k], strict=True):
            split = mask(int(kind), radii[int(kind)] + margin + sign * float(err))
            (qx, ax), (qy, ay) = divmod(pad + int(ox), factor), divmod(pad + int(oy), factor)
            ok &= split[ax][ay][qx : qx + nu, qy : qy + nv]
        free[:, :, k] = ok
    free[:, :, headings] = free[:, :, 0]  # ψ wraps: the extra slice is the first again
    labels, count = ndimage.label(free, structure=np.ones((3, 3, 3), dtype=bool))
    root = _wrap(labels, headings, count)
    start = _start_labels(mission, bounds, labels, resolution, headings)
    start_roots = {int(root[s]) for s in start}
    goals = []
    for goal in mission.get("goals", []):
        reach = _goal_labels(goal, bounds, labels, resolution, headings)
        goals.append(bool(start_roots & {int(root[x]) for x in reach}))
    return Feasibility(
        reachable=bool(goals) and all(goals),
        goals=tuple(goals),
        start_free=bool(start),
        margin=margin,
        sure=sure,
        free_fraction=float(free[:, :, :headings].mean()),
        seconds=time.perf_counter() - t0,
    )


def clearance_raster(bounds: Bounds, obstacles: Sequence[Obstacle], cap: float) -> Array:
    """Clearance (0 inside) at the raster points ``xmin + i * RASTER``, capped at ``cap``:
    each obstacle's exact distance, computed in tiles that come within ``cap`` of it."""
    nx = round((bounds.xmax - bounds.xmin) / RASTER) + 1
    ny = round((bounds.ymax - bounds.ymin) / RASTER) + 1
    xs = bounds.xmin + RASTER * np.arange(nx)
    ys = bounds.ymin + RASTER * np.arange(ny)
    walls = np.minimum(
        np.minimum(xs - bounds.xmin, bounds.xmax - xs)[:, None],
        np.minimum(ys - bounds.ymin, bounds.ymax - ys)[None, :],
    )
    out: Array = np.minimum(walls, cap)
    half = TILE * RASTER / 2 * math.sqrt(2)
    for ob in obstacles:
        x0, y0, x1, y1 = ob.bounding_box()
        i0 = max(0, int((x0 - cap - bounds.xmin) / RASTER))
        i1 = min(nx, int((x1 + cap - bounds.xmin) / RASTER) + 2)
        j0 = max(0, int((y0 - cap - bounds.ymin) / RASTER))
        j1 = min(ny, int((y1 + cap - bounds.ymin) / RASTER) + 2)
        for ti in range(i0, i1, TILE):
            for tj in range(j0, j1, TILE):
                si, sj = slice(ti, min(ti + TILE, i1)), slice(tj, min(tj + TILE, j1))
                centre = np.array([[xs[si].mean(), ys[sj].mean()]])
                if _distance(ob, centre)[0] > cap + half:
                    continue  # a long or rotated wall's box holds many tiles far from it
                px, py = np.meshgrid(xs[si], ys[sj], indexing="ij")
                points = np.stack([px.ravel(), py.ravel()], axis=-1)
                d = _distance(ob, points).reshape(px.shape)
                out[si, sj] = np.minimum(out[si, sj], d)
    return out


def _distance(ob: Obstacle, points: Array) -> Array:
    if isinstance(ob, Circle):
        d: Array = np.hypot(points[:, 0] - ob.x, points[:, 1] - ob.y) - ob.radius
        return np.maximum(d, 0.0)
    return ob.segment_clearance(points, points)


def _samples(headings: int) -> tuple[NDArray[np.int64], NDArray[np.int64], Array]:
    """Per heading, the capsules' axis samples relative to the centroid in raster steps
    ``[K, S, 2]``, each sample's capsule kind (0 head, 1 unit) ``[S]``, and each sample's error
    bound ``[K, S]``: its rounding to the raster plus the axis sampling's sag between samples
    (a distance to a convex set along a line sags by at most step² / (8 · distance))."""
    g = DEFAULT_GEOMETRY
    psi = 2 * math.pi * np.arange(headings) / headings
    poses = np.zeros((headings, 3))
    poses[:, 2] = psi
    fp = footprint(poses, STRAIGHT)
    middle = centroid(poses, STRAIGHT)
    points, kinds, sags = [], [], []
    for part in range(5):
        a, b = fp.starts[:, part] - middle, fp.ends[:, part] - middle
        length = float(np.linalg.norm(b[0] - a[0]))
        n = max(2, math.ceil(length / AXIS_STEP) + 1)
        s = np.linspace(0.0, 1.0, n)
        points.append(a[:, None, :] + s[None, :, None] * (b - a)[:, None, :])
        radius = g.head_radius if part == 0 else g.unit_radius
        kinds += [0 if part == 0 else 1] * n
        sags += [(length / (n - 1)) ** 2 / (8 * radius)] * n
    exact = np.concatenate(points, axis=1) / RASTER  # [K, S, 2] in raster steps
    rounded = np.round(exact).astype(np.int64)
    error = np.linalg.norm(exact - rounded, axis=-1) * RASTER + np.asarray(sags)[None, :]
    return rounded, np.asarray(kinds, dtype=np.int64), error


def _wrap(labels: NDArray[np.int32], headings: int, count: int) -> NDArray[np.int64]:
    """Each label's component once ψ wraps: the last slice is the first, so their labels join."""
    parent = np.arange(count + 1, dtype=np.int64)

    def find(x: int) -> int:
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = int(parent[x])
        return x

    first, last = labels[:, :, 0], labels[:, :, headings]
    pairs = np.unique(np.stack([first[first > 0], last[first > 0]], axis=-1), axis=0)
    for a, b in pairs:
        ra, rb = find(int(a)), find(int(b))
        if ra != rb:
            parent[max(ra, rb)] = min(ra, rb)
    roots = np.array([find(i) for i in range(count + 1)], dtype=np.int64)
    return roots


def _free_voxels(labels: NDArray[np.int32], cells: NDArray[np.int64]) -> list[int]:
    """Labels of the free configurations at grid cells ``[N, 3]`` (u, v, k) inside the grid."""
    nu, nv = labels.shape[:2]
    u, v = cells[:, 0], cells[:, 1]
    cells = cells[(u >= 0) & (u < nu) & (v >= 0) & (v < nv)]
    got = labels[cells[:, 0], cells[:, 1], cells[:, 2]]
    return [int(x) for x in got[got > 0]]


def _start_labels(
    mission: Mapping[str, Any],
    bounds: Bounds,
    labels: NDArray[np.int32],
    resolution: float,
    headings: int,
) -> list[int]:
    """Labels of the free configurations round the start: the grid cells and headings that
    bracket its centroid and heading."""
    s = mission.get("start", {})
    pose = np.array([float(s.get("x", 0.0)), float(s.get("y", 0.0)), float(s.get("psi", 0.0))])
    c = centroid(pose, STRAIGHT)
    u = (c[0] - bounds.xmin) / resolution
    v = (c[1] - bounds.ymin) / resolution
    k = (pose[2] % (2 * math.pi)) / (2 * math.pi / headings)
    cells = [
        (uu, vv, kk % headings)
        for uu in (math.floor(u), math.ceil(u))
        for vv in (math.floor(v), math.ceil(v))
        for kk in (math.floor(k), math.ceil(k))
    ]
    return _free_voxels(labels, np.array(cells, dtype=np.int64))


def _goal_labels(
    goal: Mapping[str, Any],
    bounds: Bounds,
    labels: NDArray[np.int32],
    resolution: float,
    headings: int,
) -> list[int]:
    """Labels of the free configurations whose tracked point is on the goal: per heading, the
    centroids within the goal's reach of the goal plus the centroid's offset at that heading."""
    gx, gy = float(goal["x"]), float(goal["y"])
    reach = max(GOAL_MIN, GOAL_FRACTION * float(goal.get("tolerance", 0.1)))
    n = math.ceil(reach / resolution)
    du, dv = np.meshgrid(np.arange(-n - 1, n + 2), np.arange(-n - 1, n + 2), indexing="ij")
    out: list[int] = []
    for k in range(headings):
        psi = 2 * math.pi * k / headings
        c = centroid(np.array([gx, gy, psi]), STRAIGHT)
        u0 = round((c[0] - bounds.xmin) / resolution)
        v0 = round((c[1] - bounds.ymin) / resolution)
        u, v = u0 + du, v0 + dv
        head_x = bounds.xmin + u * resolution - (c[0] - gx)
        head_y = bounds.ymin + v * resolution - (c[1] - gy)
        near = np.hypot(head_x - gx, head_y - gy) <= reach
        cells = np.stack([u[near], v[near], np.full(int(near.sum()), k)], axis=-1)
        out += _free_voxels(labels, cells.astype(np.int64))
    return out


def _shape(mission: Mapping[str, Any]) -> str:
    shape = mission.get("shape", "straight")
    if isinstance(shape, Mapping):
        joints = shape.get("joints", (0.0, 0.0, 0.0))
        return "straight" if all(abs(float(j)) < 1e-9 for j in joints) else "custom"
    return str(shape)

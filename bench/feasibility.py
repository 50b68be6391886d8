"""Whether a mission's body, starting straight, can reach its goals at all, with every
obstacle known: a configuration-space flood fill, independent of the planner (sim/ geometry,
numpy and scipy; the library's shape table for what the body may bend into).

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

The body may also change shape in place, as the planner's lattice lets it: ``reshape=True``
adds a layer per library shape (arc, zigzag, ...) on a grid of the tracked point instead of the
centroid, joined to the straight layer where the straight body, the other shape and every
shape between them (joints in steps of ``JOINT_STEP``) are free at the same pose. A bent slot
the straight body cannot turn through is often passable for the arc. ``verdict`` asks the
straight body first and the reshaping body only when that fails.
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

from primitives.shapes import FIXED_SHAPES, SHAPES
from sim.obstacles import Circle, Obstacle, obstacle_from_dict
from sim.robot import DEFAULT_GEOMETRY, Array, centroid_offset, rotate
from sim.world import Bounds, footprint

MARGIN = 0.01  # m of clearance a feasible world keeps (the planner keeps 0.02)
GOAL_FRACTION = 0.6  # of a goal's tolerance: how near the tracked point counts
GOAL_MIN = 0.03  # m: the nearest the planner's goal test ever asks for
RASTER = 0.005  # m between the points where clearance is computed exactly
AXIS_STEP = 0.0125  # m between the samples along a capsule's axis
RESHAPE_STEP = 0.025  # m between them for the shapes of a reshape (their sag is in the error)
RESOLUTION = 0.025  # m between the configurations' reference points
HEADINGS = 128  # heading steps of 2.8°
JOINT_STEP = 0.125  # rad: the largest joint change between shapes checked along a reshape
TILE = 100  # raster points per side of the tiles one obstacle's distances are computed in
BIN = 0.00025  # m: thresholds are binned (rounded the safe way) so a few masks serve them all
REACH = 1.1  # m: no body point lies further than this from the tracked point or the centroid
STRAIGHT = np.zeros(3)

Mask = NDArray[np.bool_]
Labels = NDArray[np.int32]


@dataclass(frozen=True)
class Feasibility:
    """One flood fill's answer."""

    reachable: bool  # every goal, in the start's component
    goals: tuple[bool, ...]  # each goal reachable from the start
    start_free: bool  # some configuration next to the start is free
    margin: float
    sure: bool  # errors added to the margin (True) or subtracted from it
    reshape: bool  # the body may change shape in place
    free_fraction: float  # of the straight body's configurations
    seconds: float


@dataclass(frozen=True)
class Verdict:
    """What a generated world is: feasible (straight, or only by reshaping), infeasible, or
    borderline (feasible at margin 0 only, or not certainly at ``MARGIN``)."""

    feasible: bool  # for sure, at MARGIN
    borderline: bool  # not feasible for sure, but not infeasible at margin 0 either
    reshape: bool  # feasible only if the body changes shape on the way
    seconds: float

    @property
    def label(self) -> str:
        if self.feasible:
            return "reshape" if self.reshape else "feasible"
        return "borderline" if self.borderline else "infeasible"


def verdict(mission: Mapping[str, Any], **grid: Any) -> Verdict:
    """Feasible for sure at ``MARGIN`` for the straight body, or else for a body that may
    reshape; if neither, whether it is infeasible even at margin 0 with the raster's error in
    the body's favour (else borderline)."""
    t0 = time.perf_counter()
    if check(mission, MARGIN, sure=True, **grid).reachable:
        return Verdict(True, False, False, time.perf_counter() - t0)
    if check(mission, MARGIN, sure=True, reshape=True, **grid).reachable:
        return Verdict(True, False, True, time.perf_counter() - t0)
    loose = check(mission, 0.0, sure=False, **grid).reachable or (
        check(mission, 0.0, sure=False, reshape=True, **grid).reachable
    )
    return Verdict(False, loose, False, time.perf_counter() - t0)


def check(
    mission: Mapping[str, Any],
    margin: float = MARGIN,
    sure: bool = True,
    resolution: float = RESOLUTION,
    headings: int = HEADINGS,
    reshape: bool = False,
) -> Feasibility:
    """The flood fill for a mission in its JSON form (its body starts straight)."""
    t0 = time.perf_counter()
    if _shape(mission) != "straight":
        raise ValueError("feasibility: only a body that starts straight is checked")
    space = _Space(mission, margin, sure, resolution, headings)
    goals = list(mission.get("goals", []))
    # The straight body's grid is of its centroid (a heading step swings its ends half as far
    # as about the head); shapes joined by a reshape share a grid of the tracked point.
    ref = np.zeros(2) if reshape else centroid_offset(STRAIGHT)
    if reshape:
        # On the tracked point's grid the head and unit 1 do not move when the joints do: one
        # mask of them serves every shape, which is then asked about units 2-4 only.
        rigid = space.free(STRAIGHT, ref, parts=(0, 1), step=RESHAPE_STEP)
        free = space.free(STRAIGHT, ref, parts=(2, 3, 4), step=RESHAPE_STEP, base=rigid)
    else:
        free = space.free(STRAIGHT, ref)
    labels, roots = space.label(free)
    union = _Union()
    start = {int(roots[x]) for x in space.start_labels(labels, ref)}
    ends = [{int(roots[x]) for x in space.goal_labels(g, labels, ref)} for g in goals]
    if reshape:
        for i, name in enumerate(n for n in FIXED_SHAPES if n != "straight"):
            base = (i + 1) << 32  # this layer's component ids
            joints = np.asarray(SHAPES[name].joints, dtype=float)
            steps = max(1, math.ceil(float(np.max(np.abs(joints))) / JOINT_STEP))
            both = free.copy()
            for j in range(1, steps + 1):
                bent = joints * j / steps
                layer = space.free(bent, ref, parts=(2, 3, 4), step=RESHAPE_STEP, base=rigid)
                both &= layer
            other, other_roots = space.label(layer)
            for x, y in _pairs(roots[labels[both]], other_roots[other[both]]):
                union.join(x, y + base)
            for g, found in zip(goals, ends, strict=True):
                found |= {int(other_roots[x]) + base for x in space.goal_labels(g, other, ref)}
    reached = {union.find(s) for s in start}
    per_goal = tuple(any(union.find(e) in reached for e in found) for found in ends)
    return Feasibility(
        reachable=bool(per_goal) and all(per_goal),
        goals=per_goal,
        start_free=bool(start),
        margin=margin,
        sure=sure,
        reshape=reshape,
        free_fraction=float(free[:, :, :headings].mean()),
        seconds=time.perf_counter() - t0,
    )


class _Union:
    """Components joined across layers (union-find over component ids)."""

    def __init__(self) -> None:
        self.parent: dict[int, int] = {}

    def find(self, x: int) -> int:
        parent = self.parent
        root = x
        while parent.get(root, root) != root:
            root = parent[root]
        while parent.get(x, x) != root:  # path compression
            parent[x], x = root, parent[x]
        return root

    def join(self, a: int, b: int) -> None:
        ra, rb = self.find(a), self.find(b)
        if ra != rb:
            self.parent[max(ra, rb)] = min(ra, rb)


class _Space:
    """One mission's arena at one margin: the clearance raster, the binned masks read from it,
    the configuration grid and how configurations are labelled and found."""

    def __init__(
        self,
        mission: Mapping[str, Any],
        margin: float,
        sure: bool,
        resolution: float,
        headings: int,
    ) -> None:
        b = mission.get("bounds", {})
        self.bounds = Bounds(
            float(b.get("xmin", -10.0)),
            float(b.get("xmax", 10.0)),
            float(b.get("ymin", -10.0)),
            float(b.get("ymax", 10.0)),
        )
        self.factor = round(resolution / RASTER)
        if self.factor < 1 or not math.isclose(self.factor * RASTER, resolution):
            raise ValueError(f"resolution: a multiple of {RASTER} m")
        self.mission, self.margin, self.sure = mission, margin, sure
        self.resolution, self.headings = resolution, headings
        obstacles = [obstacle_from_dict(dict(o)) for o in mission.get("obstacles", [])]
        cap = DEFAULT_GEOMETRY.unit_radius + margin + RASTER + 0.002
        self.clearance = clearance_raster(self.bounds, obstacles, cap)
        self.pad = math.ceil(REACH / RASTER) + 1
        self.nu = int((self.bounds.xmax - self.bounds.xmin) / resolution) + 1
        self.nv = int((self.bounds.ymax - self.bounds.ymin) / resolution) + 1
        # Per binned threshold, the padded mask split by raster phase: a sample's column of
        # the configuration grid is then one contiguous slice (strided reads were 3x slower).
        self._phases: dict[tuple[int, int], list[list[Mask]]] = {}

    def _mask(self, kind: int, need: float) -> list[list[Mask]]:
        key = (kind, math.ceil(need / BIN) if self.sure else int(need // BIN))
        got = self._phases.get(key)
        if got is None:
            full = np.pad(self.clearance >= key[1] * BIN, self.pad, constant_values=False)
            f = self.factor
            got = [[np.ascontiguousarray(full[a::f, b::f]) for b in range(f)] for a in range(f)]
            self._phases[key] = got
        return got

    def free(
        self,
        joints: Array,
        ref: Array,
        parts: Sequence[int] = range(5),
        step: float = AXIS_STEP,
        base: Mask | None = None,
    ) -> Mask:
        """Free configurations ``[nu, nv, K + 1]`` of the body with ``joints`` whose reference
        point (``ref`` from the tracked point, body frame) is on the grid, asking only the
        capsules ``parts`` (0 the head, 1-4 the units) of configurations free in ``base``; the
        last heading slice repeats the first (ψ wraps)."""
        radii = (DEFAULT_GEOMETRY.head_radius, DEFAULT_GEOMETRY.unit_radius)
        offsets, of_part, slack = _samples(self.headings, joints, ref, step)
        sign = 1.0 if self.sure else -1.0
        nu, nv, f = self.nu, self.nv, self.factor
        out = np.ones((nu, nv, self.headings + 1), dtype=bool) if base is None else base.copy()
        asked = np.isin(of_part, np.asarray(parts))
        for k in range(self.headings):
            ok = out[:, :, k].copy()  # a contiguous slice: and-ing into the strided one is slow
            for (ox, oy), part, err in zip(
                offsets[k][asked], of_part[asked], slack[k][asked], strict=True
            ):
                kind = min(int(part), 1)
                split = self._mask(kind, radii[kind] + self.margin + sign * float(err))
                (qx, ax), (qy, ay) = divmod(self.pad + int(ox), f), divmod(self.pad + int(oy), f)
                ok &= split[ax][ay][qx : qx + nu, qy : qy + nv]
            out[:, :, k] = ok
        out[:, :, self.headings] = out[:, :, 0]
        return out

    def label(self, free: Mask) -> tuple[Labels, NDArray[np.int64]]:
        """Components of the free configurations (26-neighbours) and each label's component
        once ψ wraps (the last slice is the first, so their labels join)."""
        labels = np.empty(free.shape, dtype=np.int32)  # half of what label allocates itself
        count = ndimage.label(free, structure=np.ones((3, 3, 3), dtype=bool), output=labels)
        return labels, _wrap(labels, self.headings, int(count))

    def start_labels(self, labels: Labels, ref: Array) -> list[int]:
        """Labels of the free configurations round the start: the grid cells and headings
        that bracket its reference point and heading."""
        s = self.mission.get("start", {})
        psi = float(s.get("psi", 0.0))
        at = np.array([float(s.get("x", 0.0)), float(s.get("y", 0.0))]) + rotate(ref, np.array(psi))
        u = (at[0] - self.bounds.xmin) / self.resolution
        v = (at[1] - self.bounds.ymin) / self.resolution
        k = (psi % (2 * math.pi)) / (2 * math.pi / self.headings)
        cells = [
            (uu, vv, kk % self.headings)
            for uu in (math.floor(u), math.ceil(u))
            for vv in (math.floor(v), math.ceil(v))
            for kk in (math.floor(k), math.ceil(k))
        ]
        return _free_voxels(labels, np.array(cells, dtype=np.int64))

    def goal_labels(self, goal: Mapping[str, Any], labels: Labels, ref: Array) -> list[int]:
        """Labels of the free configurations whose tracked point is on the goal: per heading,
        the grid cells within the goal's reach of the goal plus the reference's offset."""
        gx, gy = float(goal["x"]), float(goal["y"])
        reach = max(GOAL_MIN, GOAL_FRACTION * float(goal.get("tolerance", 0.1)))
        res, b = self.resolution, self.bounds
        n = math.ceil(reach / res)
        du, dv = np.meshgrid(np.arange(-n - 1, n + 2), np.arange(-n - 1, n + 2), indexing="ij")
        out: list[int] = []
        for k in range(self.headings):
            off = rotate(ref, np.array(2 * math.pi * k / self.headings))
            u = round((gx + off[0] - b.xmin) / res) + du
            v = round((gy + off[1] - b.ymin) / res) + dv
            head_x = b.xmin + u * res - off[0]
            head_y = b.ymin + v * res - off[1]
            near = np.hypot(head_x - gx, head_y - gy) <= reach
            cells = np.stack([u[near], v[near], np.full(int(near.sum()), k)], axis=-1)
            out += _free_voxels(labels, cells.astype(np.int64))
        return out


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


def _samples(
    headings: int, joints: Array, ref: Array, step: float = AXIS_STEP
) -> tuple[NDArray[np.int64], NDArray[np.int64], Array]:
    """Per heading, the capsules' axis samples (every ``step`` or less) of the body with
    ``joints`` relative to its reference point (``ref`` from the tracked point, body frame) in
    raster steps ``[K, S, 2]``, each sample's part (0 the head, 1-4 the units) ``[S]``, and
    each sample's error bound ``[K, S]``: its rounding to the raster plus the axis sampling's
    sag between samples (a distance to a convex set along a line sags by at most step² /
    (8 · distance))."""
    g = DEFAULT_GEOMETRY
    psi = 2 * math.pi * np.arange(headings) / headings
    poses = np.zeros((headings, 3))
    poses[:, 2] = psi
    fp = footprint(poses, joints)
    middle = rotate(np.broadcast_to(ref, (headings, 2)), psi)
    points, parts, sags = [], [], []
    for part in range(5):
        a, b = fp.starts[:, part] - middle, fp.ends[:, part] - middle
        length = float(np.linalg.norm(b[0] - a[0]))
        n = max(2, math.ceil(length / step) + 1)
        s = np.linspace(0.0, 1.0, n)
        points.append(a[:, None, :] + s[None, :, None] * (b - a)[:, None, :])
        radius = g.head_radius if part == 0 else g.unit_radius
        parts += [part] * n
        sags += [(length / (n - 1)) ** 2 / (8 * radius)] * n
    exact = np.concatenate(points, axis=1) / RASTER  # [K, S, 2] in raster steps
    rounded = np.round(exact).astype(np.int64)
    error = np.linalg.norm(exact - rounded, axis=-1) * RASTER + np.asarray(sags)[None, :]
    return rounded, np.asarray(parts, dtype=np.int64), error


def _wrap(labels: NDArray[np.int32], headings: int, count: int) -> NDArray[np.int64]:
    """Each label's component once ψ wraps: the last slice is the first, so their labels join."""
    parent = np.arange(count + 1, dtype=np.int64)

    def find(x: int) -> int:
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = int(parent[x])
        return x

    first, last = labels[:, :, 0], labels[:, :, headings]
    for a, b in _pairs(first[first > 0], last[first > 0]):
        ra, rb = find(int(a)), find(int(b))
        if ra != rb:
            parent[max(ra, rb)] = min(ra, rb)
    roots = np.array([find(i) for i in range(count + 1)], dtype=np.int64)
    return roots


def _pairs(a: NDArray[np.integer[Any]], b: NDArray[np.integer[Any]]) -> list[tuple[int, int]]:
    """The distinct pairs (a[i], b[i]) of two arrays of labels (each one int64 key: sorting
    rows of a 2-D array took seconds for millions of configurations)."""
    if not a.size:
        return []
    span = int(b.max()) + 1
    keys = np.unique(a.astype(np.int64) * span + b.astype(np.int64))
    return [(int(k // span), int(k % span)) for k in keys]


def _free_voxels(labels: NDArray[np.int32], cells: NDArray[np.int64]) -> list[int]:
    """Labels of the free configurations at grid cells ``[N, 3]`` (u, v, k) inside the grid."""
    nu, nv = labels.shape[:2]
    u, v = cells[:, 0], cells[:, 1]
    cells = cells[(u >= 0) & (u < nu) & (v >= 0) & (v < nv)]
    got = labels[cells[:, 0], cells[:, 1], cells[:, 2]]
    return [int(x) for x in got[got > 0]]


def _shape(mission: Mapping[str, Any]) -> str:
    shape = mission.get("shape", "straight")
    if isinstance(shape, Mapping):
        joints = shape.get("joints", (0.0, 0.0, 0.0))
        return "straight" if all(abs(float(j)) < 1e-9 for j in joints) else "custom"
    return str(shape)

"""The lattice's motions: the library's lattice primitives, precomputed for every heading.

An action applies one lattice primitive of the library from a state's representative pose
(the centroid at the cell centre, the bin's heading exactly): the primitive's recorded end pose
(where it really lands, from the library) gives the next state. For each heading a motion
carries what checking and pricing it needs, computed once per shape:

- the **swept sample points**: points along the body's capsule axes at every recorded pose
  (thinned so no body point moves more than ``SAMPLE_SPACING`` between them), each with the
  clearance it needs (its capsule's radius). A motion is valid where every point keeps its need
  plus the margin from the lethal layer;
- its **length**: how far the body's points travel on average (a translation's distance; a turn
  in place sweeps its body's points round arcs), the metres the search counts;
- its **new cells**: the costmap cells the body covers during the motion that it did not cover
  at its start, each flagged **blind** when no head ray looked at it before the body got there.
  Only the head senses: moving head first, its rays sweep the way and the flanks before the
  units arrive; a turn in place swings the tail, a sideways or tail-first move leads with the
  body, through cells nothing has seen. What those cells risk is the motion's, in its cost
  (``domain.navigation.lattice.costs``).

A fixed shape holds its joints throughout; a periodic gait's motion carries the joints of each
swept pose (its start and end shape is the table's ``joints``), so its sample points are those
of the body as it bends along the cycle (its new cells: the resting body's, see below).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import NDArray

from domain.kernels import jit
from domain.navigation.lattice.grid import compose
from domain.navigation.settings import NavigationSettings
from primitives.library import Library, Primitive
from sim.robot import DEFAULT_GEOMETRY, Array, RobotGeometry, centroid_offset, head_tip, rotate
from sim.sensors import RangeSensor, forward_ir, range_ring
from sim.world import footprint

SAMPLE_SPACING = 0.04  # metres between checked points along a capsule and between swept poses
AREA_SPACING = 0.025  # metres between the body's area samples and along a ray (half a cell)
STENCIL_REACH = 64  # cells either way a motion's blind cells may lie from its start cell


@dataclass(frozen=True)
class HeadView:
    """The head's rays as the planner assumes them: angles from the head's forward direction
    (radians, counter-clockwise) and each ray's range (metres). Occlusion is not modelled: a ray
    is taken to see its whole range."""

    angles: tuple[float, ...]
    ranges: tuple[float, ...]

    @classmethod
    def of(cls, sensors: tuple[RangeSensor, ...]) -> HeadView:
        """The rays of a sensor layout (``sim.sensors``)."""
        angles, ranges = [], []
        for sensor in sensors:
            for a in sensor.ray_angles():
                angles.append(float(a))
                ranges.append(float(sensor.max_range))
        return cls(tuple(angles), tuple(ranges))

    @classmethod
    def default(cls) -> HeadView:
        """The default robot's: the forward IR (0.8 m) and a ring of eight rays (1 m)."""
        return cls.of((*forward_ir(0.8), *range_ring(8, 1.0)))


def tail_lead(motion: Motion) -> float:
    """How far the tail leads a translation, ``(1 + cos θ) / 2`` of the angle θ between its
    direction and the body's axis towards the tail: 0 head first, 1/2 sideways, 1 tail first; 0
    for a turn in place (its swinging ends pay for what they sweep blind instead)."""
    dx, dy = float(motion.end[0]), float(motion.end[1])
    length = math.hypot(dx, dy)
    if length < 1e-9 or motion.turn != 0.0:
        return 0.0
    return 0.5 * (1.0 + dx / length)  # e(ψ), the body frame's x axis, points to the tail


@dataclass(frozen=True)
class Motion:
    """One lattice primitive of the library as the planner uses it."""

    primitive: str  # library id
    end: Array  # tracked-point end pose (dx, dy, dψ) in the start frame, as recorded
    swept: Array  # tracked-point poses along the motion, start frame, [S, 3] (the start first)
    duration: float  # model seconds
    turn: float = 0.0  # the heading change it was learned for (rad; 0: a translation)
    joints: Array | None = None  # [S, 3] the joints at each swept pose (None: the table's)

    @classmethod
    def of(cls, entry: Primitive) -> Motion:
        assert entry.end_pose is not None
        return cls(
            entry.id,
            np.asarray(entry.end_pose, dtype=float),
            np.asarray(entry.swept or [(0.0, 0.0, 0.0), entry.end_pose], dtype=float),
            float(entry.rollout.duration),
            float(entry.turn),
            np.asarray(entry.swept_joints, dtype=float) if entry.swept_joints else None,
        )


def primitive_name(primitive: str) -> str:
    """A portable PDDL name for a library id (lower case, letters, digits and ``-``)."""
    text = "".join(c if c.isalnum() or c == "-" else "_" for c in primitive.lower())
    return text if text[:1].isalpha() else f"p-{text}"


def capsule_samples(starts: Array, ends: Array, radii: Array) -> tuple[Array, Array]:
    """Points along capsule axes ``[..., C, 2]`` no further apart than SAMPLE_SPACING, and
    the clearance each needs (its capsule's radius); flattened to ``[N, 2]`` and ``[N]``."""
    length = float(np.max(np.linalg.norm(ends - starts, axis=-1)))
    n = max(2, math.ceil(length / SAMPLE_SPACING) + 1)
    s = np.linspace(0.0, 1.0, n)[:, None, None]  # [n, 1, 1]
    pts = starts[..., None, :, :] + s * (ends - starts)[..., None, :, :]  # [..., n, C, 2]
    need = np.broadcast_to(radii, pts.shape[:-1])
    return pts.reshape(-1, 2), need.reshape(-1)


def _per_bin(starts: Array, ends: Array, radii: Array) -> tuple[list[Array], list[Array]]:
    """``capsule_samples`` of each orientation bin's capsules (``[K, ..., C, 2]``), as lists
    over the bins; the points per capsule are counted per bin, as they would be one by one."""
    length = np.max(np.linalg.norm(ends - starts, axis=-1).reshape(len(starts), -1), axis=-1)
    counts = np.maximum(2, np.ceil(length / SAMPLE_SPACING).astype(np.int64) + 1)
    if np.all(counts == counts[0]):  # (a rigid body: always, but for rounding)
        pts, need = capsule_samples(starts, ends, radii)
        return list(pts.reshape(len(starts), -1, 2)), list(need.reshape(len(starts), -1))
    out = [capsule_samples(a, b, radii) for a, b in zip(starts, ends, strict=True)]
    return [p for p, _ in out], [n for _, n in out]


def thin(poses: Array, reach: float) -> Array:
    """Swept poses thinned so no body point moves more than SAMPLE_SPACING between them."""
    return np.asarray(poses[thin_indices(poses, reach)])


def thin_indices(poses: Array, reach: float, joints: Array | None = None) -> list[int]:
    """Indices of ``thin``'s poses; with ``joints`` (one row per pose) a bend moves the
    body's points too (by at most ``reach`` times the joints' summed change)."""
    keep = [0]
    for n in range(1, len(poses)):
        d = np.abs(poses[n] - poses[keep[-1]])
        moved = math.hypot(d[0], d[1]) + reach * d[2]
        if joints is not None:
            moved += reach * float(np.sum(np.abs(joints[n] - joints[keep[-1]])))
        if moved > SAMPLE_SPACING:
            keep.append(n)
    if not np.array_equal(poses[keep[-1]], poses[-1]) or (
        joints is not None and not np.array_equal(joints[keep[-1]], joints[-1])
    ):
        keep.append(len(poses) - 1)
    return keep


def area_samples(joints: Array, geometry: RobotGeometry) -> Array:
    """Points ``[N, 2]`` covering the resting body at the zero pose, ``AREA_SPACING`` apart."""
    fp = footprint(np.zeros(3), joints, geometry)
    a, b, radii = fp.starts, fp.ends, fp.radii
    lo = np.min(np.minimum(a, b) - radii[:, None], axis=0)
    hi = np.max(np.maximum(a, b) + radii[:, None], axis=0)
    # Samples at the centres of a grid of AREA_SPACING squares (never on the body's edge, where
    # rounding would put them in the cell beyond).
    xs = np.arange(lo[0] + AREA_SPACING / 2, hi[0], AREA_SPACING)
    ys = np.arange(lo[1] + AREA_SPACING / 2, hi[1], AREA_SPACING)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    pts = np.stack([gx.ravel(), gy.ravel()], -1)
    ab = b - a
    t = np.clip(
        np.einsum("pcd,cd->pc", pts[:, None, :] - a[None], ab)
        / np.maximum(np.einsum("cd,cd->c", ab, ab), 1e-12),
        0.0,
        1.0,
    )
    gap = np.linalg.norm(pts[:, None, :] - (a[None] + t[..., None] * ab[None]), axis=-1)
    out: Array = pts[np.any(gap <= radii[None], axis=-1)]
    return out


def ray_samples(view: HeadView, geometry: RobotGeometry) -> Array:
    """Points ``[N, 2]`` along the head's rays at the zero pose, ``AREA_SPACING`` apart."""
    tip = head_tip(np.zeros(3), geometry)
    forward = math.pi  # at ψ = 0 the head looks along -x (e(ψ) points to the tail)
    parts = [np.zeros((0, 2))]
    for angle, reach in zip(view.angles, view.ranges, strict=True):
        d = np.arange(AREA_SPACING, reach + 1e-9, AREA_SPACING)
        direction = np.array([math.cos(forward + angle), math.sin(forward + angle)])
        parts.append(tip[None, :2] + d[:, None] * direction[None])
    return np.concatenate(parts)


@dataclass
class MotionTable:
    """The motions of one shape, precomputed for every orientation bin."""

    shape: str
    joints: Array
    motions: list[Motion]
    settings: NavigationSettings
    view: HeadView = field(default_factory=HeadView.default)
    geometry: RobotGeometry = DEFAULT_GEOMETRY
    offset: Array = field(init=False)  # body-frame centroid offset from the tracked point
    deltas: NDArray[np.int64] = field(init=False)  # [K, M, 3] (di, dj, dk)
    points: list[Array] = field(init=False)  # per bin: swept sample points rel. to the centroid
    needs: list[Array] = field(init=False)  # per bin: clearance each point needs
    segments: list[NDArray[np.int64]] = field(init=False)  # per bin: start index per motion
    names: list[str] = field(init=False)  # PDDL names of the motions' primitives
    lengths: Array = field(init=False)  # [M] metres each motion's body points travel on average
    leads: Array = field(init=False)  # [M] how far the tail leads: 0 head first, 1 tail first
    cells: list[NDArray[np.int64]] = field(init=False)  # per bin: new cells (di, dj, blind) [N, 3]
    cell_segments: list[NDArray[np.int64]] = field(init=False)  # per bin: [M + 1] bounds
    checks: list[NDArray[np.int64]] = field(init=False)  # per bin: cells a motion's points fall in
    check_needs: list[Array] = field(init=False)  # per bin: the centre's clearance that passes all
    check_fails: list[Array] = field(init=False)  # per bin: ... below which some point fails
    check_points: list[NDArray[np.int64]] = field(init=False)  # per bin: [C + 1] points' bounds
    grouped: list[Array] = field(init=False)  # per bin: the points by cell (x, y, need) [P, 3]
    check_segments: list[NDArray[np.int64]] = field(init=False)  # per bin: [M + 1] bounds
    body_checks: list[NDArray[np.int64]] = field(init=False)  # per bin: the resting body's cells
    body_check_needs: list[Array] = field(init=False)
    open_clearance: float = field(init=False)  # centroid clearance that frees every motion
    body_points: list[Array] = field(init=False)  # per bin: the resting body's sample points
    body_needs: list[Array] = field(init=False)
    heads: list[tuple[float, float]] = field(init=False)  # per bin: tracked point - centroid
    _distinct: list[tuple[Array, NDArray[np.intp]] | None] = field(
        init=False, repr=False, compare=False
    )

    def __post_init__(self) -> None:
        self.names = [primitive_name(m.primitive) for m in self.motions]
        self.offset = centroid_offset(self.joints, self.geometry)
        reach = self.geometry.body_length
        K, r = self.settings.orientations, self.settings.resolution
        M = len(self.motions)
        self.deltas = np.zeros((K, M, 3), dtype=np.int64)
        self._distinct = [None] * K
        # Every orientation at once (one batch per motion): each value is computed by the same
        # elementwise operations as one pose at a time, ~20x faster than a loop over bins.
        psi = np.asarray(np.arange(K) * self.settings.step, dtype=np.float64)
        starts = np.concatenate([np.zeros(2) - rotate(self.offset, psi), psi[:, None]], axis=-1)
        self.heads = [(float(x), float(y)) for x, y in starts[:, :2]]
        fp0 = footprint(starts, self.joints, self.geometry)
        p0, n0 = _per_bin(fp0.starts, fp0.ends, fp0.radii)
        self.body_points, self.body_needs = p0, n0
        area = area_samples(self.joints, self.geometry)
        rays = ray_samples(self.view, self.geometry)
        pts_m: list[list[Array]] = []
        need_m: list[list[Array]] = []
        cells_m: list[list[NDArray[np.int64]]] = []
        lengths = []
        for m, motion in enumerate(self.motions):
            end = compose(starts, motion.end)
            c = self.centroid(end)
            self.deltas[:, m, 0] = np.round(c[:, 0] / r)
            self.deltas[:, m, 1] = np.round(c[:, 1] / r)
            self.deltas[:, m, 2] = round(float(motion.end[2]) / self.settings.step)
            # The start pose too: a state's representative pose is where the previous move
            # landed, snapped to the lattice, so it was not checked by that move.
            kept = thin_indices(motion.swept, reach, motion.joints)
            poses = motion.swept[kept]
            bent = None if motion.joints is None else motion.joints[kept]
            swept = compose(starts[:, None, :], poses)  # [K, S, 3]
            fp = footprint(swept, self.joints if bent is None else bent, self.geometry)
            pts, need = _per_bin(fp.starts, fp.ends, fp.radii)
            pts_m.append(pts)
            need_m.append(need)
            lengths.append(_travel(poses, area))
            # The new cells (what a move risks) are the resting body's: a gait's swinging tail
            # keeps within 0.09 m of the straight body (primitives/shapes.py), beside cells the
            # head's side rays cross as it passes them, cycle after cycle; counted per motion
            # as blind, the tail's swing would charge every head-first step for cells it
            # sweeps again and again. Validity (the sample points above) is the bent body's.
            cells_m.append(_new_cells(swept, area, rays, r))
        self.lengths = np.array(lengths, dtype=np.float64)
        self.leads = np.array([tail_lead(m) for m in self.motions], dtype=np.float64)
        self.points, self.needs, self.segments = [], [], []
        self.cells, self.cell_segments = [], []
        for k in range(K):
            self.points.append(np.concatenate([p[k] for p in pts_m]))
            self.needs.append(np.concatenate([n[k] for n in need_m]))
            sizes = [len(p[k]) for p in pts_m]
            self.segments.append(np.concatenate([[0], np.cumsum(sizes[:-1])]).astype(np.int64))
            cells = [c[k] for c in cells_m]
            self.cells.append(np.concatenate(cells) if cells else np.zeros((0, 3), np.int64))
            bounds = np.concatenate([[0], np.cumsum([len(c) for c in cells])])
            self.cell_segments.append(bounds.astype(np.int64))
        self.checks, self.check_needs, self.check_segments = [], [], []
        self.check_fails, self.check_points, self.grouped = [], [], []
        self.body_checks, self.body_check_needs = [], []
        for k in range(K):
            body = _cell_checks(self.body_points[k], self.body_needs[k], r)
            self.body_checks.append(body.cells)
            self.body_check_needs.append(body.passes)
            motions = _cell_checks(self.points[k], self.needs[k], r, self.segments[k])
            self.checks.append(motions.cells)
            self.check_needs.append(motions.passes)
            self.check_fails.append(motions.fails)
            self.grouped.append(motions.points)
            self.check_segments.append(motions.group_bounds)
            self.check_points.append(motions.bounds)
        # Clearance at the centroid beyond which every motion is free (clearance is
        # 1-Lipschitz: no point lies further than `reach` from the centroid).
        self.open_clearance = max(
            float(np.max(np.linalg.norm(p, axis=-1) + n))
            for p, n in zip(self.points, self.needs, strict=True)
        )

    # -- poses --------------------------------------------------------------------------------
    @cached_property
    def reach(self) -> float:
        """How far any motion's swept sample points lie from its start centroid, metres."""
        return max(float(np.max(np.linalg.norm(p, axis=-1))) for p in self.points)

    @cached_property
    def largest_need(self) -> float:
        """The largest clearance any swept sample point needs (before the margin), metres."""
        return max(float(np.max(n)) for n in self.needs)

    @cached_property
    def cell_reach_new(self) -> int:
        """The most cells any new cell lies from its motion's start cell, along either axis."""
        return max((int(np.max(np.abs(c[:, :2]), initial=0)) for c in self.cells), default=0)

    @cached_property
    def turn_cost(self) -> float:
        """Metres a turn in place costs per radian of heading (the cheapest turn's), the unit
        in which a heuristic counts headings still to turn."""
        per = [
            float(self.lengths[n]) / abs(float(m.end[2]))
            for n, m in enumerate(self.motions)
            if abs(float(m.end[2])) > 1e-3
        ]
        return min(per, default=0.0)

    @cached_property
    def turn_room(self) -> float:
        """How far sideways the resting body's farthest point from the centroid moves in one
        heading step (m): the room a passage must leave the body to change its heading."""
        farthest = max(float(np.max(np.hypot(p[:, 0], p[:, 1]))) for p in self.body_points)
        return 2.0 * farthest * math.sin(self.settings.step / 2)

    @cached_property
    def blind_per_radian(self) -> float:
        """How many blind cells a turn in place sweeps per radian (the fewest of the shape's
        turns, averaged over headings): what the heuristic counts a turn onto the way by."""
        per = []
        for m, motion in enumerate(self.motions):
            turn = abs(float(motion.end[2]))
            if turn < 1e-3:
                continue
            counts = [
                int(np.sum(c[s[m] : s[m + 1], 2]))
                for c, s in zip(self.cells, self.cell_segments, strict=True)
            ]
            per.append(float(np.mean(counts)) / turn)
        return min(per, default=0.0)

    def distinct(self, k: int) -> tuple[Array, NDArray[np.intp]]:
        """Bin ``k``'s distinct swept sample points and, for each of ``points[k]``, its row
        among them (a quarter of the points repeat: every motion starts from the resting
        body), so a check looks clearance up once per distinct point. Made on first use."""
        got = self._distinct[k]
        if got is None:
            # As complex numbers: a 1-D sort in (x, y) order, ~10x np.unique(axis=0)'s speed.
            flat = np.ascontiguousarray(self.points[k], dtype=np.float64).view(np.complex128)
            unique, inverse = np.unique(flat.ravel(), return_inverse=True)
            rows = np.ascontiguousarray(unique).view(np.float64).reshape(-1, 2)
            got = self._distinct[k] = (rows, inverse.reshape(-1).astype(np.intp))
        return got

    @cached_property
    def cell_reach(self) -> list[int]:
        """Per bin: the most cells any motion moves the centroid along either axis."""
        return [int(np.max(np.abs(d[:, :2]), initial=0)) for d in self.deltas]

    def heading(self, k: int) -> float:
        return k * self.settings.step

    def centroid(self, pose: Array) -> Array:
        """World centroid of tracked-point poses ``[..., 3]``."""
        out: Array = pose[..., :2] + rotate(self.offset, pose[..., 2])
        return out

    @cached_property
    def _centroid_offsets(self) -> list[tuple[float, float]]:
        """Per orientation bin, the centroid's offset from the tracked point (a plan's every
        state reads one: a list lookup, not a rotation)."""
        psi = np.arange(self.settings.orientations, dtype=np.float64) * self.settings.step
        return [(float(x), float(y)) for x, y in rotate(self.offset[None, :], psi)]

    def pose_of_centroid(self, c: Array, k: int) -> Array:
        """The tracked-point pose whose centroid is ``c`` at orientation bin ``k``."""
        return np.array(self.pose_tuple(float(c[0]), float(c[1]), k))

    def pose_tuple(self, cx: float, cy: float, k: int) -> tuple[float, float, float]:
        """``pose_of_centroid`` as three floats."""
        ox, oy = self._centroid_offsets[k % self.settings.orientations]
        return (cx - ox, cy - oy, self.heading(k))

    def centroid_need(self) -> float:
        """Clearance the centroid itself needs: how deep it lies inside the body's capsules."""
        fp = footprint(np.zeros(3), self.joints, self.geometry)
        c = self.offset
        ab = fp.ends - fp.starts
        s = np.clip(np.sum((c - fp.starts) * ab, -1) / np.maximum(np.sum(ab * ab, -1), 1e-12), 0, 1)
        d = np.linalg.norm(fp.starts + s[:, None] * ab - c, axis=-1)
        return float(max(0.0, np.max(fp.radii - d)))


@dataclass(frozen=True)
class CellChecks:
    """A motion's sample points by the cell they fall in: the cells (offsets from the start
    cell, whose centre is the centroid's), the clearance at a cell's centre at which every
    point in it keeps its need (``passes``: the largest need there plus its point's offset
    from the centre, |dx| + |dy|) and below which one cannot (``fails``: the largest need less
    that offset), the points grouped by cell (x, y, need) and each cell's bounds among them.
    The clearance between centres is bilinear in a grid of a 1-Lipschitz distance, and a
    bilinear value differs from the nearest centre's by at most |dx| + |dy|: a check reads one
    centre per cell, and the points themselves only where the centre lies between the two."""

    cells: NDArray[np.int64]
    passes: Array
    fails: Array
    points: Array
    bounds: NDArray[np.int64]
    group_bounds: NDArray[np.int64]
    """where each group's cells begin among ``cells`` (and their end)"""


def _cell_checks(
    points: Array, needs: Array, resolution: float, segments: NDArray[np.int64] | None = None
) -> CellChecks:
    """``CellChecks`` of sample points (relative to the centroid) and their needs, the points
    in groups (a bin's motions: ``segments``, where each group's points begin; one group
    without) whose cells are each group's own, in group order, each group's sorted by cell.
    One sort over every group's points: a motion table has one such set per bin."""
    n = len(points)
    starts = np.zeros(1, dtype=np.int64) if segments is None else np.asarray(segments, np.int64)
    group = np.repeat(np.arange(len(starts)), np.diff(np.append(starts, n)))
    cells = np.floor(points / resolution + 0.5).astype(np.int64)
    off = np.sum(np.abs(points - cells * resolution), axis=-1)
    # A key ordered as (group, cell row, cell column) lexicographically: one 1-D sort.
    low = cells.min(axis=0, initial=0)
    span = cells.max(axis=0, initial=0) - low + 1
    key = (group * span[0] + (cells[:, 0] - low[0])) * span[1] + (cells[:, 1] - low[1])
    order = np.argsort(key, kind="stable")
    ordered = key[order]
    first = np.flatnonzero(np.diff(ordered, prepend=-1)) if n else np.zeros(0, np.int64)
    bounds = np.append(first, n).astype(np.int64)
    if n:
        passes = np.maximum.reduceat((needs + off)[order], first)
        fails = np.maximum.reduceat((needs - off)[order], first)
    else:
        passes = fails = np.zeros(0)
    grouped = np.column_stack([points[order], needs[order]])
    group_bounds = np.searchsorted(group[order][first], np.arange(len(starts) + 1))
    return CellChecks(
        cells[order[first]], passes, fails, grouped, bounds, group_bounds.astype(np.int64)
    )


def _travel(poses: Array, area: Array) -> float:
    """Metres the body's area samples travel on average along ``poses`` (the start frame)."""
    psi = poses[:, 2]
    world = poses[:, None, :2] + rotate(area[None, :, :], psi[:, None])  # [S, N, 2]
    steps = np.linalg.norm(np.diff(world, axis=0), axis=-1)  # [S - 1, N]
    return float(np.mean(np.sum(steps, axis=0)))


def _new_cells(
    swept: Array, area: Array, rays: Array, resolution: float
) -> list[NDArray[np.int64]]:
    """Per bin (``swept``: each bin's poses along the motion ``[K, S, 3]``, its start
    centroid at the origin): the cells (offsets from the start cell and a blind flag,
    ``[N, 3]``) the body covers along the poses but not at the first; blind where no ray
    sample saw the cell at an earlier pose."""
    side = 2 * STENCIL_REACH + 1
    return [
        _first_cover_and_sight(
            np.ascontiguousarray(bin_swept), area, rays, resolution, STENCIL_REACH, side
        )
        for bin_swept in swept
    ]


@jit
def _first_cover_and_sight(  # pragma: no cover - compiled
    swept: Array, area: Array, rays: Array, resolution: float, reach: int, side: int
) -> NDArray[np.int64]:
    """The new cells of one bin's motion (see ``_new_cells``), row-major order."""
    never = swept.shape[0] + 1
    cover = np.full(side * side, never, dtype=np.int64)
    sight = np.full(side * side, never, dtype=np.int64)
    for s in range(swept.shape[0]):
        x, y, psi = swept[s, 0], swept[s, 1], swept[s, 2]
        c, n = math.cos(psi), math.sin(psi)
        for q in range(area.shape[0]):
            px = x + c * area[q, 0] - n * area[q, 1]
            py = y + n * area[q, 0] + c * area[q, 1]
            i = int(math.floor(px / resolution + 0.5)) + reach
            j = int(math.floor(py / resolution + 0.5)) + reach
            if 0 <= i < side and 0 <= j < side and s < cover[i * side + j]:
                cover[i * side + j] = s
        for q in range(rays.shape[0]):
            px = x + c * rays[q, 0] - n * rays[q, 1]
            py = y + n * rays[q, 0] + c * rays[q, 1]
            i = int(math.floor(px / resolution + 0.5)) + reach
            j = int(math.floor(py / resolution + 0.5)) + reach
            if 0 <= i < side and 0 <= j < side and s < sight[i * side + j]:
                sight[i * side + j] = s
    count = 0
    for cell in range(side * side):
        if 1 <= cover[cell] < never:
            count += 1
    out = np.empty((count, 3), dtype=np.int64)
    count = 0
    for cell in range(side * side):
        if 1 <= cover[cell] < never:
            out[count, 0] = cell // side - reach
            out[count, 1] = cell % side - reach
            out[count, 2] = 1 if sight[cell] >= cover[cell] else 0
            count += 1
    return out


def held_joints(joints: Sequence[float]) -> tuple[float, float, float]:
    """The joint angles a body's lattice is made for: the sensed ones to 0.05 rad (the
    footprint of the real body; one motion table per rounded shape: every caller passes
    these to ``motion_table``, so that all find the same table of a shape)."""
    a, b, c = (round(v / 0.05) * 0.05 for v in joints)
    return (a, b, c)


_TABLES: dict[tuple[Any, ...], tuple[tuple[Primitive, ...], MotionTable | None]] = {}
TABLE_CACHE = 64  # motion tables kept per process (each ~0.3 s to build)


def motion_table(
    library: Library,
    shape: str,
    joints: tuple[float, float, float],
    settings: NavigationSettings,
    view: HeadView | None = None,
    geometry: RobotGeometry = DEFAULT_GEOMETRY,
) -> MotionTable | None:
    """The shape's lattice primitives as a motion table, or ``None`` if the library has none.

    Tables are kept per process, keyed by the shape's entries (the objects: a library made
    with a newly learned shape holds the same ones for every other shape, so its tables stay),
    joints, the lattice's settings and the head's view: every mission of a worker reuses them."""
    view = view if view is not None else HeadView.default()
    lattice = (settings.resolution, settings.orientations)
    entries = tuple(library.lattice(shape))
    key = (shape, tuple(map(id, entries)), joints, lattice, view, geometry)
    cached = _TABLES.get(key)
    if cached is not None:
        return cached[1]
    table = (
        MotionTable(
            shape,
            np.asarray(joints, float),
            [Motion.of(e) for e in entries],
            settings,
            view,
            geometry,
        )
        if entries
        else None
    )
    if len(_TABLES) >= TABLE_CACHE:
        _TABLES.clear()
    _TABLES[key] = (entries, table)  # the entries are held so their ids cannot be reused
    return table


def body_key(table: MotionTable) -> tuple[Any, ...]:
    """What a heuristic map, a motion cache or a feasibility answer depends on of the body:
    its shape, the joints its table was made for and the head's view."""
    return (table.shape, tuple(np.round(table.joints, 3)), table.view)

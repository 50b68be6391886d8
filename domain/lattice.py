"""The state lattice: (centroid cell, orientation, shape) states and library primitives as motions.

A state is the cell of the body centroid (the reference point: every shape turns in place
about it) and one of ``orientations`` headings. Its representative pose puts the centroid at
the cell centre with the bin's heading exactly. An action applies one lattice primitive of the
library from that pose: the primitive's recorded end pose (where it really lands, from the
library) gives the next pose, snapped to its state. A motion is valid where the footprint swept
along the primitive's recorded poses keeps ``margin`` clear of everything in the world model.

For each orientation the world offsets of every motion (next cell, swept sample points with the
clearance each needs) are computed once, so checking the successors of a state is one
vectorised clearance lookup.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import NDArray

from primitives.library import Library, Primitive
from sim.robot import DEFAULT_GEOMETRY, Array, RobotGeometry, centroid_offset, rotate
from sim.world import Bounds, footprint

SAMPLE_SPACING = 0.04  # metres between checked points along a capsule and between swept poses
Key = tuple[int, int, int]  # centroid cell (i, j) and orientation bin k


@dataclass(frozen=True)
class LatticeSettings:
    """Resolution of the lattice and the clearance kept around the swept body."""

    resolution: float = 0.05  # metres per centroid cell
    orientations: int = 64  # headings per turn (5.625° apart)
    margin: float = 0.01  # metres the swept footprint keeps from anything occupied
    start_margin: float = 0.0  # margin for motions out of the start (it may touch a contact)

    def __post_init__(self) -> None:
        if not (0.01 <= self.resolution <= 0.5):
            raise ValueError("resolution: must lie within [0.01, 0.5] m")
        if self.orientations < 16 or self.orientations % 4:
            raise ValueError("orientations: need at least 16, a multiple of 4")
        if not (0 <= self.margin <= 0.2 and 0 <= self.start_margin <= self.margin):
            raise ValueError("margin: must lie within [0, 0.2] m and start_margin <= margin")

    @property
    def step(self) -> float:
        return 2 * math.pi / self.orientations


@dataclass(frozen=True)
class Motion:
    """One lattice primitive of the library as the planner uses it."""

    primitive: str  # library id
    end: Array  # tracked-point end pose (dx, dy, dψ) in the start frame, as recorded
    swept: Array  # tracked-point poses along the motion, start frame, [S, 3]
    duration: float  # model seconds

    @classmethod
    def of(cls, entry: Primitive) -> Motion:
        assert entry.end_pose is not None
        return cls(
            entry.id,
            np.asarray(entry.end_pose, dtype=float),
            np.asarray(entry.swept or [entry.end_pose], dtype=float),
            float(entry.rollout.duration),
        )


def compose(pose: Array, delta: Array) -> Array:
    """``pose ∘ delta`` for poses ``[..., 3]``: ``delta`` expressed in ``pose``'s frame."""
    xy = pose[..., :2] + rotate(delta[..., :2], pose[..., 2])
    return np.concatenate([xy, (pose[..., 2] + delta[..., 2])[..., None]], axis=-1)


def relative(pose: Array, target: Array) -> Array:
    """``pose⁻¹ ∘ target``: where ``target`` lies in the frame of ``pose`` (both ``[3]``)."""
    xy = rotate(target[:2] - pose[:2], np.array(-pose[2]))
    turn = math.remainder(float(target[2] - pose[2]), 2 * math.pi)
    return np.array([xy[0], xy[1], turn])


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


def _thin(poses: Array, reach: float) -> Array:
    """Swept poses thinned so no body point moves more than SAMPLE_SPACING between them."""
    keep = [poses[0]]
    for pose in poses[1:]:
        d = np.abs(pose - keep[-1])
        if math.hypot(d[0], d[1]) + reach * d[2] > SAMPLE_SPACING:
            keep.append(pose)
    if not np.array_equal(keep[-1], poses[-1]):
        keep.append(poses[-1])
    return np.array(keep)


@dataclass
class MotionTable:
    """The motions of one shape, precomputed for every orientation bin."""

    shape: str
    joints: Array
    motions: list[Motion]
    settings: LatticeSettings
    geometry: RobotGeometry = DEFAULT_GEOMETRY
    offset: Array = field(init=False)  # body-frame centroid offset from the tracked point
    deltas: NDArray[np.int64] = field(init=False)  # [K, M, 3] (di, dj, dk)
    points: list[Array] = field(init=False)  # per bin: swept sample points rel. to the centroid
    needs: list[Array] = field(init=False)  # per bin: clearance each point needs
    segments: list[NDArray[np.int64]] = field(init=False)  # per bin: start index per motion
    names: list[str] = field(init=False)  # PDDL names of the motions' primitives
    open_clearance: float = field(init=False)  # centroid clearance that frees every motion
    body_points: list[Array] = field(init=False)  # per bin: the resting body's sample points
    body_needs: list[Array] = field(init=False)
    heads: list[tuple[float, float]] = field(init=False)  # per bin: tracked point - centroid
    _distinct: list[tuple[Array, NDArray[np.intp]] | None] = field(
        init=False, repr=False, compare=False
    )

    def __post_init__(self) -> None:
        from domain.lattice_task import primitive_name  # names only; no import cycle at load

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
        pts_m: list[list[Array]] = []
        need_m: list[list[Array]] = []
        for m, motion in enumerate(self.motions):
            end = compose(starts, motion.end)
            c = self.centroid(end)
            self.deltas[:, m, 0] = np.round(c[:, 0] / r)
            self.deltas[:, m, 1] = np.round(c[:, 1] / r)
            self.deltas[:, m, 2] = round(float(motion.end[2]) / self.settings.step)
            # The start pose too: a state's representative pose is where the previous move
            # landed, snapped to the lattice, so it was not checked by that move.
            swept = compose(starts[:, None, :], _thin(motion.swept, reach))  # [K, S, 3]
            fp = footprint(swept, self.joints, self.geometry)
            pts, need = _per_bin(fp.starts, fp.ends, fp.radii)
            pts_m.append(pts)
            need_m.append(need)
        self.points, self.needs, self.segments = [], [], []
        for k in range(K):
            self.points.append(np.concatenate([p[k] for p in pts_m]))
            self.needs.append(np.concatenate([n[k] for n in need_m]))
            sizes = [len(p[k]) for p in pts_m]
            self.segments.append(np.concatenate([[0], np.cumsum(sizes[:-1])]).astype(np.int64))
        # Clearance at the centroid beyond which every motion is free (clearance is
        # 1-Lipschitz: no point lies further than `reach` from the centroid).
        self.open_clearance = max(
            float(np.max(np.linalg.norm(p, axis=-1) + n))
            for p, n in zip(self.points, self.needs, strict=True)
        )

    # -- poses --------------------------------------------------------------------------------
    @cached_property
    def longest_step(self) -> float:
        """The longest straight translation among the motions, metres (at least 1 mm): the
        unit the lattice heuristics count moves in."""
        step = max(
            (float(np.hypot(*m.end[:2])) for m in self.motions if abs(m.end[2]) < 1e-3),
            default=0.25,
        )
        return max(step, 1e-3)

    @cached_property
    def reach(self) -> float:
        """How far any motion's swept sample points lie from its start centroid, metres."""
        return max(float(np.max(np.linalg.norm(p, axis=-1))) for p in self.points)

    @cached_property
    def largest_need(self) -> float:
        """The largest clearance any swept sample point needs (before the margin), metres."""
        return max(float(np.max(n)) for n in self.needs)

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

    @cached_property
    def largest_turn(self) -> float:
        """The largest change of heading of one motion, radians."""
        return max((abs(float(m.end[2])) for m in self.motions), default=math.pi)

    def heading(self, k: int) -> float:
        return k * self.settings.step

    def centroid(self, pose: Array) -> Array:
        """World centroid of tracked-point poses ``[..., 3]``."""
        out: Array = pose[..., :2] + rotate(self.offset, pose[..., 2])
        return out

    def pose_of_centroid(self, c: Array, k: int) -> Array:
        """The tracked-point pose whose centroid is ``c`` at orientation bin ``k``."""
        psi = self.heading(k)
        return np.array([*(c - rotate(self.offset, np.array(psi))), psi])


def body_key(table: MotionTable) -> tuple[Any, ...]:
    """What a distance map, a motion cache or a reachability answer depends on of the body:
    its shape and the joints its table was made for (one shape's tables differ in the
    centroid's need, the head's offset and the swept footprints)."""
    return (table.shape, tuple(np.round(table.joints, 3)))


@dataclass(frozen=True)
class LatticeGrid:
    """Where the lattice's cells lie: ``nx × ny`` centroid cells over the arena."""

    bounds: Bounds
    settings: LatticeSettings

    # Cached: searches ask for these on every state they touch.
    @cached_property
    def nx(self) -> int:
        return max(1, math.ceil((self.bounds.xmax - self.bounds.xmin) / self.settings.resolution))

    @cached_property
    def ny(self) -> int:
        return max(1, math.ceil((self.bounds.ymax - self.bounds.ymin) / self.settings.resolution))

    @cached_property
    def centres(self) -> Array:
        """Every cell centre ``[nx * ny, 2]``, cell (i, j) at row ``i * ny + j``."""
        r = self.settings.resolution
        xs = self.bounds.xmin + (np.arange(self.nx) + 0.5) * r
        ys = self.bounds.ymin + (np.arange(self.ny) + 0.5) * r
        cx, cy = np.meshgrid(xs, ys, indexing="ij")
        out: Array = np.stack([cx.ravel(), cy.ravel()], -1)
        return out

    def centre(self, i: int, j: int) -> Array:
        r = self.settings.resolution
        return np.array([self.bounds.xmin + (i + 0.5) * r, self.bounds.ymin + (j + 0.5) * r])

    def cell(self, x: float, y: float) -> tuple[int, int]:
        r = self.settings.resolution
        i = min(self.nx - 1, max(0, math.floor((x - self.bounds.xmin) / r)))
        j = min(self.ny - 1, max(0, math.floor((y - self.bounds.ymin) / r)))
        return i, j

    def inside(self, i: int, j: int) -> bool:
        return 0 <= i < self.nx and 0 <= j < self.ny

    def encode(self, key: Key) -> int:
        i, j, k = key
        return (k * self.nx + i) * self.ny + j

    def decode(self, number: int) -> Key:
        rest, j = divmod(number, self.ny)
        k, i = divmod(rest, self.nx)
        return i, j, k

    @cached_property
    def size(self) -> int:
        return self.nx * self.ny * self.settings.orientations


_TABLES: dict[tuple[Any, ...], tuple[Library, MotionTable | None]] = {}
TABLE_CACHE = 64  # motion tables kept per process (each ~0.3 s to build)


def motion_table(
    library: Library,
    shape: str,
    joints: tuple[float, float, float],
    settings: LatticeSettings,
    geometry: RobotGeometry = DEFAULT_GEOMETRY,
) -> MotionTable | None:
    """The shape's lattice primitives as a motion table, or ``None`` if the library has none.

    Tables are kept per process (keyed by the library object, shape, joints and settings):
    every mission of a worker reuses them."""
    key = (id(library), shape, joints, settings, geometry)
    cached = _TABLES.get(key)
    if cached is not None and cached[0] is library:
        return cached[1]
    entries = library.lattice(shape)
    table = (
        MotionTable(
            shape, np.asarray(joints, float), [Motion.of(e) for e in entries], settings, geometry
        )
        if entries
        else None
    )
    if len(_TABLES) >= TABLE_CACHE:
        _TABLES.clear()
    _TABLES[key] = (library, table)  # the library is held so its id cannot be reused
    return table

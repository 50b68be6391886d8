"""A world's obstacles packed once into arrays, for collision and ray queries over all of them at once.

The simulator asks, every step, how far the body's five capsules are from every obstacle and
where a dozen rays first hit; answered obstacle by obstacle that is a few dozen numpy calls on
2-4-element arrays per obstacle. ``Scene`` stacks the polygons' edges (with each polygon's first
edge as a ``reduceat`` offset) and the circles' centres and radii once, so each query is a
fixed number of numpy calls whatever the obstacle count. Each answer equals, value for value,
what ``Circle`` / ``Polygon`` compute one at a time (the same formulas, element by element);
``tests/sim/test_scene.py`` holds them to it.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from sim.obstacles import (
    Circle,
    Obstacle,
    point_segment_distance,
    ray_segment_hits,
    segments_intersect,
)
from sim.robot import Array

Index = NDArray[np.intp]
INDEX_MIN = 1000  # obstacles from which a scene buckets its boxes (below, testing all is cheaper)
INDEX_CELL = 0.5  # m: the buckets' size, about the body's width plus a step
INDEX_SPAN = 64  # buckets a box may cover before it is kept apart, tested on every query


class BoxIndex:
    """Bounding boxes bucketed in a uniform grid of ``INDEX_CELL`` cells (each box in every
    bucket it overlaps, as compressed rows), so that the boxes that may come near a query box
    are found from the few buckets it touches, not by testing every box: with 10,000 posts the
    simulator's per-step question would otherwise scan all of them. Boxes spanning more than
    ``INDEX_SPAN`` buckets (a long wall) are kept apart and always tested."""

    def __init__(self, boxes: NDArray[np.float64], cell: float = INDEX_CELL) -> None:
        self.cell = cell
        self.origin = boxes[:, :2].min(axis=0)
        first = np.floor((boxes[:, :2] - self.origin) / cell).astype(np.intp)
        last = np.floor((boxes[:, 2:] - self.origin) / cell).astype(np.intp)
        self.shape = (int(last[:, 0].max()) + 1, int(last[:, 1].max()) + 1)
        span = (last - first + 1).prod(axis=1)
        big = span > INDEX_SPAN
        self.big: Index = np.flatnonzero(big)
        ids, cells = [], []
        small = np.flatnonzero(~big)
        width = last - first + 1
        for di in range(int(width[small, 0].max(initial=0))):
            for dj in range(int(width[small, 1].max(initial=0))):
                sel = small[(width[small, 0] > di) & (width[small, 1] > dj)]
                ids.append(sel)
                cells.append((first[sel, 0] + di) * self.shape[1] + first[sel, 1] + dj)
        flat_ids = np.concatenate([np.zeros(0, np.intp), *ids])
        flat_cells = np.concatenate([np.zeros(0, np.intp), *cells])
        order = np.argsort(flat_cells, kind="stable")
        self.ids: Index = flat_ids[order]
        counts = np.bincount(flat_cells, minlength=self.shape[0] * self.shape[1])
        self.starts: Index = np.concatenate([[0], np.cumsum(counts)]).astype(np.intp)

    def candidates(self, lo: NDArray[np.float64], hi: NDArray[np.float64], margin: float) -> Index:
        """Sorted ids of the boxes in the buckets the box ``lo``-``hi`` grown by ``margin``
        touches (a superset of those within ``margin`` of it), and the big ones."""
        i0, j0 = np.floor((lo - margin - self.origin) / self.cell).astype(np.intp).tolist()
        i1, j1 = np.floor((hi + margin - self.origin) / self.cell).astype(np.intp).tolist()
        i0, j0 = max(i0, 0), max(j0, 0)
        i1, j1 = min(i1, self.shape[0] - 1), min(j1, self.shape[1] - 1)
        parts = [self.big]
        ny, starts = self.shape[1], self.starts
        for i in range(i0, i1 + 1):
            a, b = starts[i * ny + j0], starts[i * ny + j1 + 1]  # a row's buckets are contiguous
            if b > a:
                parts.append(self.ids[a:b])
        if len(parts) == 1:
            return self.big
        out: Index = np.unique(np.concatenate(parts))
        return out


class Scene:
    """Static arrays of a fixed set of obstacles; every query returns one column per obstacle,
    in the obstacles' order."""

    def __init__(self, obstacles: Sequence[Obstacle]) -> None:
        self.count = len(obstacles)
        circles = [(i, o) for i, o in enumerate(obstacles) if isinstance(o, Circle)]
        polygons = [(i, o) for i, o in enumerate(obstacles) if not isinstance(o, Circle)]
        self.circle_index: Index = np.array([i for i, _ in circles], dtype=np.intp)
        self.centres = np.array([o.centre for _, o in circles]).reshape(-1, 2)
        self.radii = np.array([o.radius for _, o in circles], dtype=float)
        self.polygon_index: Index = np.array([i for i, _ in polygons], dtype=np.intp)
        edges = [o.edges for _, o in polygons]
        self.edge_a = np.concatenate([np.zeros((0, 2)), *(a for a, _ in edges)])
        self.edge_b = np.concatenate([np.zeros((0, 2)), *(b for _, b in edges)])
        sizes = [len(a) for a, _ in edges]
        self.first_edge: Index = np.cumsum([0, *sizes[:-1]]).astype(np.intp)
        boxes = [o.bounding_box() for o in obstacles]
        self.boxes = np.array(boxes, dtype=float).reshape(-1, 4)  # [N, (x0, y0, x1, y1)]
        # Per obstacle, for the compiled kernels: its circle row (-1 for a polygon), a polygon's
        # first edge and edge count.
        self.kind = np.zeros((self.count, 3), dtype=np.int64)
        self.kind[:, 0] = -1
        self.kind[self.circle_index, 0] = np.arange(self.circle_index.size)
        self.kind[self.polygon_index, 1] = self.first_edge
        self.kind[self.polygon_index, 2] = sizes
        self.index = BoxIndex(self.boxes) if self.count >= INDEX_MIN else None
        self.all_ids = np.arange(self.count, dtype=np.int64)

    def segment_clearance(self, a: Array, b: Array) -> Array:
        """Clearance ``[C, N]`` of segments ``a-b`` ``[C, 2]`` to each obstacle (0 when touching or
        inside), as ``obstacle.segment_clearance`` gives it column by column."""
        out = np.empty((a.shape[0], self.count))
        if self.circle_index.size:
            near = point_segment_distance(self.centres[:, None, :], a, b)  # [Nc, C]
            out[:, self.circle_index] = np.maximum(near - self.radii[:, None], 0.0).T
        if self.polygon_index.size:
            d = self._segment_distance(a, b)  # [C, E]
            nearest = np.minimum.reduceat(d, self.first_edge, axis=1)  # [C, Np]
            inside = self.contains_polygon(np.concatenate([a, b]))  # [2C, Np]
            touching = inside[: a.shape[0]] | inside[a.shape[0] :]
            out[:, self.polygon_index] = np.where(touching, 0.0, nearest)
        return out

    def _segment_distance(self, a: Array, b: Array) -> Array:
        """``segment_segment_distance`` of every segment ``a-b`` ``[C, 2]`` to every edge, ``[C, E]``:
        its four point-segment distances as two calls on stacked ends (the same values, since a
        minimum is exact whatever the order)."""
        ea, eb = self.edge_a, self.edge_b
        ends = np.stack([a, b])[:, :, None, :]  # [2, C, 1, 2]: segment ends against edges
        corners = np.stack([ea, eb])[:, None, :, :]  # [2, 1, E, 2]: edge ends against segments
        to_edges = point_segment_distance(ends, ea, eb).min(axis=0)
        to_segments = point_segment_distance(corners, a[:, None, :], b[:, None, :]).min(axis=0)
        dist = np.minimum(to_edges, to_segments)
        crossing = segments_intersect(a[:, None, :], b[:, None, :], ea, eb)
        return np.where(crossing, 0.0, dist)

    def contains_polygon(self, points: Array) -> NDArray[np.bool_]:
        """Whether points ``[P, 2]`` lie inside each polygon (even-odd rule), ``[P, Np]``."""
        ea, eb = self.edge_a, self.edge_b
        px, py = points[:, None, 0], points[:, None, 1]
        ax, ay, bx, by = ea[:, 0], ea[:, 1], eb[:, 0], eb[:, 1]
        straddle = (ay > py) != (by > py)
        with np.errstate(divide="ignore", invalid="ignore"):
            x_cross = ax + (py - ay) * (bx - ax) / (by - ay)
        crossed = (straddle & (px < x_cross)).astype(np.intp)
        crossings = np.add.reduceat(crossed, self.first_edge, axis=1)
        return np.asarray(crossings % 2 == 1)

    def ray_cast(self, origin: Array, dirs: Array) -> Array:
        """Distance along unit rays ``dirs`` ``[R, 2]`` from ``origin`` to each obstacle (inf if
        missed, 0 from inside), ``[R, N]``, as ``obstacle.ray_cast`` gives it."""
        out = np.empty((dirs.shape[0], self.count))
        if self.circle_index.size:
            out[:, self.circle_index] = self.circle_ray_cast(origin, dirs)
        if self.polygon_index.size:
            hits = ray_segment_hits(origin, dirs, self.edge_a, self.edge_b)  # [R, E]
            first = np.minimum.reduceat(hits, self.first_edge, axis=1)
            inside = self.contains_polygon(origin[None, :])[0]  # [Np]
            out[:, self.polygon_index] = np.where(inside, 0.0, first)
        return out

    def circle_ray_cast(self, origin: Array, dirs: Array) -> Array:
        """Distance along unit rays ``dirs`` ``[R, 2]`` to each circle, ``[R, circles]``."""
        rel = origin - self.centres  # [Nc, 2]
        # One small product per circle: a batched product may round differently, and the
        # readings must stay those of ``Circle.ray_cast``.
        bq = np.stack([dirs @ r for r in rel], axis=-1)  # [R, Nc]
        cq = np.array([r @ r for r in rel]) - self.radii**2
        disc = bq * bq - cq
        root = np.sqrt(np.maximum(disc, 0.0))
        near, far = -bq - root, -bq + root
        t = np.where(near >= 0, near, np.where(far >= 0, 0.0, np.inf))
        out: Array = np.where(disc >= 0, t, np.inf)
        return out

    def circle_products(self, origin: Array, dirs: Array) -> tuple[Array, Array]:
        """The products ``circle_ray_cast`` starts from, as it computes them (one small product
        per circle): ``dirs @ rel`` ``[circles, R]`` and ``rel @ rel`` ``[circles]``, with
        ``rel = origin - centre`` (``collision_kernel.circle_distances`` does the rest)."""
        rel = origin - self.centres
        bq = np.empty((rel.shape[0], dirs.shape[0]))
        rr = np.empty(rel.shape[0])
        for c, r in enumerate(rel):
            bq[c] = dirs @ r
            rr[c] = r @ r
        return bq, rr

    def near(self, lo: Array, hi: Array, margin: float) -> Index:
        """Indices of obstacles whose bounding boxes come within ``margin`` of the box
        ``lo``-``hi`` (a cheap test: the rest cannot be closer than ``margin``)."""
        if self.index is None:
            b = self.boxes
            close = (
                (b[:, 0] <= hi[0] + margin)
                & (b[:, 2] >= lo[0] - margin)
                & (b[:, 1] <= hi[1] + margin)
                & (b[:, 3] >= lo[1] - margin)
            )
            return np.flatnonzero(close)
        ids = self.index.candidates(np.asarray(lo), np.asarray(hi), margin)
        b = self.boxes[ids]
        close = (
            (b[:, 0] <= hi[0] + margin)
            & (b[:, 2] >= lo[0] - margin)
            & (b[:, 1] <= hi[1] + margin)
            & (b[:, 3] >= lo[1] - margin)
        )
        out: Index = ids[close]
        return out

    def candidate_ids(self, lo: Array, hi: Array, margin: float) -> NDArray[np.int64]:
        """Ids of the obstacles that may come within ``margin`` of the box (every one without
        an index), for a compiled loop that tests their boxes itself."""
        if self.index is None:
            return self.all_ids
        return self.index.candidates(lo, hi, margin).astype(np.int64)

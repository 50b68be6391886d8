"""A roadmap over free space: an 8-connected grid of waypoints, obstacles inflated.

Waypoints closer to an obstacle than ``inflation`` (the robot's half-width plus a margin) are
dropped, as are edges whose segment passes closer than that. Extra nodes (the start pose and
the goals) connect to the grid waypoints around them. Edges can be blocked later by sensed
obstacles without rebuilding anything.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from sim.obstacles import Obstacle
from sim.robot import Array
from sim.world import Bounds, footprint

GRID_DIRECTIONS = ((1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1))
MAX_NODES = 40_000
Mask = NDArray[np.bool_]


def heading_of(dx: float, dy: float, step: float = 45.0) -> float:
    """World-frame direction of (dx, dy) rounded to the heading grid, in (-180, 180]."""
    deg = round(math.degrees(math.atan2(dy, dx)) / step) * step
    return 180.0 if deg <= -180.0 else float(deg)


@dataclass
class Roadmap:
    """Nodes ``points[V, 2]`` and undirected edges (stored both ways) with their headings."""

    points: Array
    starts: list[int] = field(default_factory=list)
    ends: list[int] = field(default_factory=list)
    headings: list[float] = field(default_factory=list)
    grid_size: int = 0  # nodes [0, grid_size) are grid waypoints; the rest are extra nodes
    spacing: float = 1.0
    inflation: float = 0.3

    @classmethod
    def grid(
        cls,
        bounds: Bounds,
        spacing: float,
        obstacles: Sequence[Obstacle] = (),
        inflation: float = 0.3,
    ) -> Roadmap:
        if not (math.isfinite(spacing) and spacing > 0):
            raise ValueError("spacing: must be positive and finite")
        xs = np.arange(bounds.xmin + spacing / 2, bounds.xmax, spacing)
        ys = np.arange(bounds.ymin + spacing / 2, bounds.ymax, spacing)
        if xs.size * ys.size > MAX_NODES:
            raise ValueError(f"spacing: {xs.size * ys.size} waypoints exceed {MAX_NODES}")
        gx, gy = np.meshgrid(xs, ys, indexing="ij")
        points = np.stack([gx.ravel(), gy.ravel()], axis=-1)
        road = cls(points, grid_size=len(points), spacing=spacing, inflation=inflation)
        free = road.point_clear(points, obstacles, bounds)
        nx, ny = xs.size, ys.size
        a_list, b_list, h_list = [], [], []
        for dx, dy in GRID_DIRECTIONS[:4]:  # each undirected edge once
            for i in range(nx):
                for j in range(ny):
                    i2, j2 = i + dx, j + dy
                    if 0 <= i2 < nx and 0 <= j2 < ny:
                        a, b = i * ny + j, i2 * ny + j2
                        if free[a] and free[b]:
                            a_list.append(a)
                            b_list.append(b)
                            h_list.append(heading_of(dx, dy))
        a_arr, b_arr = np.array(a_list, dtype=int), np.array(b_list, dtype=int)
        ok = road.segments_clear(points[a_arr], points[b_arr], obstacles) if len(a_arr) else a_arr
        for a, b, h, keep in zip(a_list, b_list, h_list, ok, strict=True):
            if keep:
                road._add_edge(a, b, h)
        return road

    def _add_edge(self, a: int, b: int, heading: float) -> None:
        back = heading - 180.0 if heading > 0 else heading + 180.0
        self.starts += [a, b]
        self.ends += [b, a]
        self.headings += [heading, back]

    def point_clear(
        self, points: Array, obstacles: Iterable[Obstacle], bounds: Bounds | None = None
    ) -> Mask:
        ok: Mask = np.ones(len(points), dtype=bool)
        if bounds is not None:
            ok &= bounds.wall_clearance(points) >= self.inflation
        for ob in obstacles:
            ok &= ob.segment_clearance(points, points) >= self.inflation
        return ok

    def segments_clear(
        self, a: Array, b: Array, obstacles: Iterable[Obstacle], need: float | None = None
    ) -> Mask:
        """Segments that keep ``need`` (default: the inflation) from every obstacle."""
        need = self.inflation if need is None else need
        ok: Mask = np.ones(len(a), dtype=bool)
        for ob in obstacles:
            ok &= ob.segment_clearance(a, b) >= need
        return ok

    @property
    def edge_count(self) -> int:
        return len(self.starts)

    def add_node(self, x: float, y: float, obstacles: Sequence[Obstacle], bounds: Bounds) -> int:
        """Add a node at (x, y) joined to the clear grid waypoints within 1.5 spacings."""
        node = len(self.points)
        links = self.links(x, y, obstacles, bounds)
        self.points = np.vstack([self.points, [x, y]])
        for n, heading in links:
            self._add_edge(node, n, heading)
        return node

    def links(
        self,
        x: float,
        y: float,
        obstacles: Sequence[Obstacle],
        bounds: Bounds,
        escape: bool = False,
    ) -> list[tuple[int, float]]:
        """Clear grid waypoints within 1.5 spacings of (x, y), with the heading towards each.

        ``escape``: (x, y) is where the robot already is, possibly closer to an obstacle than
        the inflation (it was just sensed); links then only must not get closer than it is.
        """
        grid = self.points[: self.grid_size]
        d = np.linalg.norm(grid - [x, y], axis=-1)
        near = np.flatnonzero(d <= 1.5 * self.spacing)
        if near.size == 0:
            near = np.argsort(d)[:4]
        here = np.repeat([[x, y]], near.size, axis=0)
        need = self.inflation
        if escape:
            p = np.array([[x, y]])
            now = min([float(ob.segment_clearance(p, p)[0]) for ob in obstacles], default=np.inf)
            need = min(self.inflation, 0.9 * now)
        ok = self.segments_clear(here, grid[near], obstacles, need)
        ok &= self.point_clear(grid[near], obstacles, bounds)
        out = []
        for n in near[ok]:
            dx, dy = grid[n] - [x, y]
            if math.hypot(dx, dy) > 1e-9:
                out.append((int(n), heading_of(float(dx), float(dy))))
        return out

    def body_clear_edges(
        self,
        psi: float,
        joints: Array,
        obstacles: Sequence[Obstacle],
        bounds: Bounds,
        margin: float,
    ) -> Mask:
        """Edges along which the whole body (heading ``psi``, ``joints``) keeps ``margin`` clear.

        The head follows the edge; the body trails behind it at the current heading. Checked at
        both ends and the middle of each edge: the body translates between them.
        """
        if not self.starts:
            return np.zeros(0, dtype=bool)
        a, b = self.points[self.starts], self.points[self.ends]
        ok: Mask = np.ones(len(a), dtype=bool)
        for where in (a, b, (a + b) / 2):
            fp = footprint(np.column_stack([where, np.full(len(where), psi)]), joints)
            starts, ends, radii = fp.starts, fp.ends, fp.radii
            clear = np.ones(len(a), dtype=bool)
            for ob in obstacles:
                gap = ob.segment_clearance(starts, ends) - radii  # [E, 5]
                clear &= np.all(gap >= margin, axis=-1)
            wall = bounds.wall_clearance(np.concatenate([starts, ends], axis=-2)) - np.concatenate(
                [radii, radii]
            )
            clear &= np.all(wall >= 0, axis=-1)
            ok &= clear
        return ok

    def edges_blocked_by(self, obstacle: Obstacle) -> NDArray[np.intp]:
        """Indices of edges that pass closer than ``inflation`` to ``obstacle``."""
        if not self.starts:
            return np.zeros(0, dtype=np.intp)
        a, b = self.points[self.starts], self.points[self.ends]
        out: NDArray[np.intp] = np.flatnonzero(obstacle.segment_clearance(a, b) < self.inflation)
        return out

    def adjacency(self, active: Mask) -> dict[int, list[int]]:
        out: dict[int, list[int]] = {}
        for e in np.flatnonzero(active):
            out.setdefault(self.starts[e], []).append(self.ends[e])
        return out

    def hops_from(self, source: int, adjacency: dict[int, list[int]], size: int) -> Array:
        """Breadth-first hop counts from ``source`` (inf where unreachable), ``size`` nodes."""
        dist = np.full(size, np.inf)
        dist[source] = 0
        queue = deque([source])
        while queue:
            v = queue.popleft()
            for w in adjacency.get(v, ()):
                if dist[w] == np.inf:
                    dist[w] = dist[v] + 1
                    queue.append(w)
        return dist

"""Generated worlds for the navigation scoreboard: seeded missions, pure functions of (family, seed).

    python -m bench.worlds --family posts --seed 1000 --out posts-1000.json [--known]
    python -m bench.worlds --family posts --seeds 0-99 --gaps     # the posts' gap distribution

**The seeds are split (issue 28): tune on seeds 0-99 (``TUNING_SEEDS``); report on seeds
1000-1199 (``REPORT_SEEDS``), which nobody looks at while tuning.** A change is judged on the
report seeds once, after it is made; looking at a report world to fix it makes it a tuning
world.

Families (each a valid ``MissionSpec``: the straight body, default sensors, one goal, every
obstacle hidden unless ``known``, the start heading drawn at random, facing away included):

- ``posts``: a 4.2 m-wide field of 0.15 m posts on a 0.15 m grid from a cellular automaton
  (random fill, then steps that thin crowded posts and seed posts in holes): the gap to the
  nearest post is 0.45-0.7 m for 70 % of posts (0.3-0.85 m for 94 %); start and goal 10 m apart
  at its two ends; the long sides walled by touching posts (~225 obstacles in all);
- ``slots``: a bent slot (0.28-0.5 m wide, 1-3 bends of 30-120°, walls of rectangles) through
  a barrier that seals the arena: the slot is the only way;
- ``pipes``: the same, longer (3-5 bends of 20-90°), with hidden debris inside some;
- ``rooms``: 2-4 rooms in a row or a square with doors of 0.3-0.6 m and a few pieces of
  furniture; the goal in the farthest room;
- ``clutter``: circles, rotated rectangles and convex polygons in a 10 m × 10 m arena, gaps of
  at least 0.3 m between most.

``generate`` also asks ``bench.feasibility`` (a flood fill of the straight body with every
obstacle known, independent of the planner) whether the world can be done at all: a feasible
world expects ``succeeded`` (one the body can do only by changing shape on the way carries
``-reshape`` in its name); an infeasible one ``failed`` with ``unreachable`` (it is kept: a
sound planner must say so); a borderline one (feasible only at margin 0) expects the same
failure and carries ``-borderline`` in its name so the scoreboard lists it apart.
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage, spatial

from bench.feasibility import Verdict, verdict
from sim.obstacles import Circle, Obstacle, Polygon, obstacle_from_dict, segment_segment_distance
from sim.robot import Array
from sim.world import footprint

FAMILIES = ("posts", "slots", "pipes", "rooms", "clutter")
TUNING_SEEDS = range(0, 100)
REPORT_SEEDS = range(1000, 1200)
_SALT = {name: i + 1 for i, name in enumerate(FAMILIES)}  # one random stream per family

POST = 0.075  # post radius: 0.15 m posts on a 0.15 m grid
CELL = 0.15
WALL = 0.1  # thickness of rectangle walls
STRAIGHT = np.zeros(3)
Mission = dict[str, Any]


@dataclass(frozen=True)
class World:
    """One generated world: its mission (``expect`` filled in) and the feasibility verdict."""

    family: str
    seed: int
    mission: Mission
    verdict: Verdict

    @property
    def name(self) -> str:
        return str(self.mission["name"])


def generate(family: str, seed: int, known: bool = False) -> World:
    """The world of ``family`` and ``seed``, checked for feasibility, ``expect`` set from it."""
    mission = layout(family, seed, known)
    checked = verdict(mission)
    if checked.feasible:
        mission["expect"] = {"status": "succeeded"}
    else:
        mission["expect"] = {"status": "failed", "reason": "unreachable"}
    if checked.label != "feasible":  # reshape, borderline, infeasible: seen in any listing
        mission["name"] += f"-{checked.label}"
    return World(family, seed, mission, checked)


def layout(family: str, seed: int, known: bool = False) -> Mission:
    """The mission of ``family`` and ``seed`` without ``expect`` (no flood fill: fast)."""
    if family not in _BUILDERS:
        raise ValueError(f"family: one of {', '.join(FAMILIES)}, not {family!r}")
    if seed < 0:
        raise ValueError("seed: must be >= 0")
    rng = np.random.default_rng([_SALT[family], seed])
    mission = _BUILDERS[family](rng)
    mission["name"] = f"{family}-{seed:04d}" + ("-known" if known else "")
    mission["seed"] = seed
    for ob in mission["obstacles"]:
        ob["known"] = known
    rounded: Mission = _rounded(mission)
    return rounded


def known_twin(mission: Mission) -> Mission:
    """The same mission with every obstacle known to the planner."""
    twin: Mission = json.loads(json.dumps(mission))
    for ob in twin.get("obstacles", []):
        ob["known"] = True
    twin["name"] = f"{twin.get('name', 'mission')}-known"
    return twin


# -- geometry helpers ---------------------------------------------------------------------------
def _circle(x: float, y: float, r: float) -> dict[str, Any]:
    return {"type": "circle", "x": x, "y": y, "radius": r}


def _rect(x: float, y: float, w: float, h: float, angle: float = 0.0) -> dict[str, Any]:
    return {"type": "rectangle", "x": x, "y": y, "width": w, "height": h, "angle": angle}


def _bar(a: Array, b: Array) -> dict[str, Any]:
    """A wall (a rectangle ``WALL`` thick) along the segment a-b."""
    d = b - a
    mid = (a + b) / 2
    return _rect(float(mid[0]), float(mid[1]), float(np.hypot(*d)), WALL, math.atan2(d[1], d[0]))


def _start_pose(
    rng: np.random.Generator,
    x: float,
    ys: tuple[float, float],
    box: tuple[float, ...],
    tries: int = 200,
) -> tuple[float, float, float]:
    """A head position at ``x`` (y drawn in ``ys``) and a heading drawn uniformly, whose body
    lies inside ``box`` (xmin, xmax, ymin, ymax) with 0.1 m to spare."""
    for _ in range(tries):
        psi = float(rng.uniform(-math.pi, math.pi))
        y = float(rng.uniform(*ys))
        ends = _body_points(x, y, psi)
        if (
            ends[:, 0].min() > box[0] + 0.175
            and ends[:, 0].max() < box[1] - 0.175
            and ends[:, 1].min() > box[2] + 0.175
            and ends[:, 1].max() < box[3] - 0.175
        ):
            return x, y, psi
    raise RuntimeError("no start pose fits")  # never for the families' boxes


def _body_points(x: float, y: float, psi: float) -> Array:
    fp = footprint(np.array([x, y, psi]), STRAIGHT)
    return np.concatenate([fp.starts, fp.ends])


def _body_clearance(pose: tuple[float, float, float], ob: Obstacle) -> float:
    """Gap between the body at ``pose`` and an obstacle."""
    fp = footprint(np.array(pose), STRAIGHT)
    return float(np.min(ob.segment_clearance(fp.starts, fp.ends) - fp.radii))


def _obstacle_gap(a: Obstacle, b: Obstacle) -> float:
    """Distance between two obstacles (0 when they touch or overlap)."""
    if isinstance(a, Circle) and isinstance(b, Circle):
        return max(0.0, math.hypot(a.x - b.x, a.y - b.y) - a.radius - b.radius)
    if isinstance(a, Circle):
        a, b = b, a
    assert isinstance(a, Polygon)
    if isinstance(b, Circle):
        c = np.array([[b.x, b.y]])
        return max(0.0, float(a.segment_clearance(c, c)[0]) - b.radius)
    ea, eb = a.edges
    fa, fb = b.edges
    d = segment_segment_distance(ea[:, None, :], eb[:, None, :], fa[None], fb[None])
    if bool(np.any(a.contains(b.vertices))) or bool(np.any(b.contains(a.vertices))):
        return 0.0
    return float(d.min())


# -- posts --------------------------------------------------------------------------------------
POSTS_COLS, POSTS_ROWS = 80, 28  # 12 m x 4.2 m of 0.15 m cells
POSTS_FILL = 0.25  # the automaton's random start
POSTS_STEPS = 6  # steps that thin and seed
POSTS_SETTLE = 2  # steps that only thin, last
POSTS_THIN = 0.5  # chance a crowded post goes in a step
POSTS_SEED = 0.25  # chance a post appears in an empty cell with room round it in a step
POSTS_CROWD = 3  # cells (Chebyshev): a post with another this near is crowded
POSTS_ROOM = 4  # cells (Chebyshev): an empty cell with no post this near may get one


def posts_grid(
    rng: np.random.Generator, cols: int = POSTS_COLS, rows: int = POSTS_ROWS
) -> NDArray[np.bool_]:
    """The cellular automaton: a random fill, then steps where a post with another within
    ``POSTS_CROWD`` cells (a gap under 0.45 m) goes with chance ``POSTS_THIN`` and an empty
    cell with no post within ``POSTS_ROOM`` cells (a hole of 1.2 m or more) gets one with
    chance ``POSTS_SEED``, then steps that only thin. Gaps to the nearest post are then
    mostly 0.45-0.7 m, with a few crowded pairs left (``python -m bench.worlds --gaps``)."""
    grid = rng.random((cols, rows)) < POSTS_FILL
    near = np.ones((2 * POSTS_CROWD + 1,) * 2, dtype=np.int64)
    room = np.ones((2 * POSTS_ROOM + 1,) * 2, dtype=np.int64)
    for step in range(POSTS_STEPS + POSTS_SETTLE):
        posts = grid.astype(np.int64)
        crowded = grid & (ndimage.convolve(posts, near, mode="constant") > 1)
        thinned = grid & ~(crowded & (rng.random(grid.shape) < POSTS_THIN))
        if step < POSTS_STEPS:
            hole = ~grid & (ndimage.convolve(posts, room, mode="constant") == 0)
            thinned |= hole & (rng.random(grid.shape) < POSTS_SEED)
        grid = thinned
    return grid


def _posts(rng: np.random.Generator) -> Mission:
    x0, y0 = -CELL * POSTS_COLS / 2, -CELL * POSTS_ROWS / 2  # the field's corner: (-6, -2.1)
    xb, yb = -x0 + 0.2, -y0 + 0.25  # arena bounds: the field, its walls and a little more
    grid = posts_grid(rng)
    sx, sy, psi = _start_pose(rng, -5.0, (-1.0, 1.0), (x0, -x0, y0, -y0))
    gy = float(rng.uniform(-1.2, 1.2))
    gx = sx + math.sqrt(100.0 - (gy - sy) ** 2)  # 10 m from the start
    obstacles = []
    for i, j in zip(*np.nonzero(grid), strict=True):
        x, y = x0 + CELL * (i + 0.5), y0 + CELL * (j + 0.5)
        post = Circle(x, y, POST)
        if math.hypot(x - gx, y - gy) < 0.3 or _body_clearance((sx, sy, psi), post) < 0.12:
            continue  # room for the start's body and round the goal
        obstacles.append(_circle(x, y, POST))
    # The long sides: touching posts from bound to bound, so nothing passes outside them.
    n = round(2 * xb / CELL)
    for k in range(n):
        x = -xb + CELL * (k + 0.5)
        for y in (y0 - POST, -y0 + POST):
            obstacles.append(_circle(x, y, POST))
    return {
        "start": {"x": sx, "y": sy, "psi": psi},
        "goals": [{"x": gx, "y": gy}],
        "bounds": {"xmin": -xb, "xmax": xb, "ymin": -yb, "ymax": yb},
        "obstacles": obstacles,
    }


def post_gaps(mission: Mission) -> dict[str, Array]:
    """Gaps (surface to surface, m) between a field's posts: each post's nearest neighbour, and
    every edge of their Delaunay triangulation (the gaps a way through passes), wall posts left
    out (they touch each other)."""
    posts = [
        (o["x"], o["y"])
        for o in mission["obstacles"]
        if o["type"] == "circle" and abs(o["y"]) < CELL * POSTS_ROWS / 2
    ]
    pts = np.array(posts)
    tree = spatial.cKDTree(pts)
    d, _ = tree.query(pts, k=2)
    nearest = d[:, 1] - 2 * POST
    tri = spatial.Delaunay(pts)
    edges = {
        (min(a, b), max(a, b))
        for simplex in tri.simplices
        for a, b in ((simplex[0], simplex[1]), (simplex[1], simplex[2]), (simplex[0], simplex[2]))
    }
    e = np.array(sorted(edges))
    delaunay = np.linalg.norm(pts[e[:, 0]] - pts[e[:, 1]], axis=1) - 2 * POST
    return {"nearest": nearest, "delaunay": delaunay}


# -- slots and pipes ----------------------------------------------------------------------------
@dataclass(frozen=True)
class _Bent:
    """A bent corridor's draw: how many bends, their angles, segment lengths and widths."""

    bends: tuple[int, int]  # fewest, most
    angles: tuple[float, float]  # degrees, each bend's size
    lengths: tuple[float, float]  # m, each segment
    widths: tuple[float, float]  # m
    half: float  # the arena's half size, m
    debris: float  # chance the corridor has debris in it


SLOT = _Bent((1, 3), (30.0, 120.0), (0.8, 1.8), (0.28, 0.5), 5.0, 0.0)
PIPE = _Bent((3, 5), (20.0, 90.0), (1.0, 2.5), (0.3, 0.5), 8.0, 0.5)


def _corridor(rng: np.random.Generator, kind: _Bent, barrier: float) -> tuple[Array, float]:
    """A bent centre line that ends heading +x at the barrier (x = ``barrier``), drawn from its
    far end backwards, and its width; redrawn until it stays clear of itself and the arena."""
    for _ in range(1000):
        width = float(rng.uniform(*kind.widths))
        n = int(rng.integers(kind.bends[0], kind.bends[1] + 1))
        turns = np.radians(rng.uniform(*kind.angles, size=n)) * rng.choice([-1.0, 1.0], size=n)
        # Headings from the barrier backwards: the last segment runs along +x into it.
        headings = [0.0]
        for t in turns[::-1]:
            headings.append(headings[-1] - float(t))
        headings = headings[::-1]  # first segment (the mouth) .. last (into the barrier)
        shift = [(width / 2 + WALL) * math.tan(abs(float(t)) / 2) for t in turns]
        lengths = []
        for i in range(n + 1):
            need = (shift[i - 1] if i > 0 else 0.0) + (shift[i] if i < n else 0.0) + 0.3
            lengths.append(max(float(rng.uniform(*kind.lengths)), need))
        y_end = float(rng.uniform(-0.6, 0.6) * kind.half)
        points = [np.array([barrier + WALL, y_end])]
        for h, length in zip(headings[::-1], lengths[::-1], strict=True):
            points.append(points[-1] - length * np.array([math.cos(h), math.sin(h)]))
        line = np.array(points[::-1])  # mouth .. barrier
        if _corridor_ok(line, width, barrier, kind.half):
            return line, width
    raise RuntimeError("no corridor fits")  # never for the families' ranges


def _corridor_ok(line: Array, width: float, barrier: float, half: float) -> bool:
    """Inside the arena with room round the mouth, west of the barrier but for its last
    segment, and clear of itself (segments that do not meet keep two walls and a body apart)."""
    room = width / 2 + WALL + 1.2
    if np.any(np.abs(line[:, 1]) > half - room) or np.any(line[:, 0] < -half + room):
        return False
    if np.any(line[:-2, 0] > barrier - width / 2 - WALL - 0.3):
        return False
    a, b = line[:-1], line[1:]
    apart = width + 2 * WALL + 0.3
    for i in range(len(a)):
        for j in range(i + 2, len(a)):
            if float(segment_segment_distance(a[i], b[i], a[j], b[j])) < apart:
                return False
    return True


def _walls_of(line: Array, width: float) -> list[dict[str, Any]]:
    """Rectangles along both sides of a centre line: each wall's centre line is offset by half
    the width and half a wall, mitred at the bends, one rectangle per segment (consecutive ones
    share the mitre point, so the wall is closed)."""
    d = np.diff(line, axis=0)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    normal = np.stack([-d[:, 1], d[:, 0]], axis=1)
    walls = []
    for side in (1.0, -1.0):
        off = side * (width / 2 + WALL / 2)
        vertices = [line[0] + off * normal[0]]
        for i in range(1, len(line) - 1):
            bisector = normal[i - 1] + normal[i]
            vertices.append(line[i] + off * bisector / (1.0 + float(normal[i - 1] @ normal[i])))
        vertices.append(line[-1] + off * normal[-1])
        for p, q in itertools.pairwise(vertices):
            walls.append(_bar(p, q))
    return walls


def _bent(rng: np.random.Generator, kind: _Bent) -> Mission:
    """A barrier across the arena at x = ``barrier`` whose only way through is a bent
    corridor on the start's side; the goal beyond it."""
    half = kind.half
    barrier = float(rng.uniform(0.1, 0.25) * half)
    line, width = _corridor(rng, kind, barrier)
    obstacles = _walls_of(line, width)
    y_end = float(line[-1, 1])
    x = barrier + WALL / 2
    low, high = y_end - width / 2, y_end + width / 2
    obstacles.append(_rect(x, (-half + low) / 2, WALL, low + half))
    obstacles.append(_rect(x, (high + half) / 2, WALL, half - high))
    if rng.random() < kind.debris:
        obstacles += _debris(rng, line, width)
    walls = [obstacle_from_dict(o) for o in obstacles]
    gx = float(rng.uniform(barrier + 1.0, half - 0.6))
    gy = float(rng.uniform(-half + 0.6, half - 0.6))
    for _ in range(1000):
        sx = float(rng.uniform(-half + 0.3, barrier - 0.3))
        sy = float(rng.uniform(-half + 0.3, half - 0.3))
        psi = float(rng.uniform(-math.pi, math.pi))
        ends = _body_points(sx, sy, psi)
        if (
            ends[:, 0].min() > -half + 0.2
            and ends[:, 0].max() < barrier - 0.2
            and np.abs(ends[:, 1]).max() < half - 0.2
            and math.hypot(sx - line[0, 0], sy - line[0, 1]) > 1.5
            and all(_body_clearance((sx, sy, psi), w) > 0.25 for w in walls)
        ):
            break
    else:
        raise RuntimeError("no start fits")  # never: the start's side is mostly open
    return {
        "start": {"x": sx, "y": sy, "psi": psi},
        "goals": [{"x": gx, "y": gy}],
        "bounds": {"xmin": -half, "xmax": half, "ymin": -half, "ymax": half},
        "obstacles": obstacles,
    }


def _debris(rng: np.random.Generator, line: Array, width: float) -> list[dict[str, Any]]:
    """1-3 pieces of debris (small posts or blocks) against a wall inside straight stretches,
    away from the bends; what they leave of the width is drawn too (some leave too little)."""
    out = []
    segments = list(range(len(line) - 1))
    for _ in range(int(rng.integers(1, 4))):
        i = int(rng.choice(segments))
        a, b = line[i], line[i + 1]
        d = (b - a) / np.linalg.norm(b - a)
        n = np.array([-d[1], d[0]]) * rng.choice([-1.0, 1.0])
        along = a + (b - a) * float(rng.uniform(0.35, 0.65))
        size = float(rng.uniform(0.03, 0.07))
        at = along + n * (width / 2 - size)  # touching the wall's inner face
        if rng.random() < 0.5:
            out.append(_circle(float(at[0]), float(at[1]), size))
        else:
            angle = math.atan2(d[1], d[0]) + float(rng.uniform(-0.5, 0.5))
            out.append(_rect(float(at[0]), float(at[1]), 2 * size, 2 * size, angle))
    return out


def _slots(rng: np.random.Generator) -> Mission:
    return _bent(rng, SLOT)


def _pipes(rng: np.random.Generator) -> Mission:
    return _bent(rng, PIPE)


# -- rooms --------------------------------------------------------------------------------------
def _door_wall(
    at: float, lo: float, hi: float, door: float, centre: float, vertical: bool
) -> list[dict[str, Any]]:
    """A wall from ``lo`` to ``hi`` along one axis at ``at`` on the other, with a door of width
    ``door`` centred at ``centre``."""
    out = []
    for a, b in ((lo, centre - door / 2), (centre + door / 2, hi)):
        if b - a > 1e-6:
            mid, length = (a + b) / 2, b - a
            if vertical:
                out.append(_rect(at, mid, WALL, length))
            else:
                out.append(_rect(mid, at, length, WALL))
    return out


def _rooms(rng: np.random.Generator) -> Mission:
    """2-4 rooms in a row, or four in a square; a door of 0.3-0.6 m in each wall between
    rooms (three of the square's four); up to two pieces of furniture per room; the start in
    the first room, the goal in the farthest."""
    count = int(rng.integers(2, 5))
    walls: list[dict[str, Any]] = []
    doors: list[tuple[float, float]] = []

    def door(lo: float, hi: float) -> tuple[float, float]:
        width = float(rng.uniform(0.3, 0.6))
        return width, float(rng.uniform(lo + 0.5 + width / 2, hi - 0.5 - width / 2))

    if count == 4 and rng.random() < 0.5:  # a square of rooms: SW, SE, NW, NE
        h = float(rng.uniform(2.5, 3.5))
        rooms = [(-h, 0.0, -h, 0.0), (0.0, h, -h, 0.0), (-h, 0.0, 0.0, h), (0.0, h, 0.0, h)]
        closed = int(rng.integers(4))  # three arms of the cross have doors: still connected
        arms = [(True, -h, 0.0), (True, 0.0, h), (False, -h, 0.0), (False, 0.0, h)]
        for k, (vertical, lo, hi) in enumerate(arms):
            if k == closed:
                w, c = 0.0, lo
            else:
                w, c = door(lo, hi)
            walls += _door_wall(0.0, lo, hi, w, c, vertical)
            if w:
                doors.append((0.0, c) if vertical else (c, 0.0))
        bounds = (-h, h, -h, h)
        first, last = rooms[0], rooms[3]
    else:
        widths = rng.uniform(2.5, 3.5, size=count)
        height = float(rng.uniform(3.0, 4.5))
        edges = np.concatenate([[0.0], np.cumsum(widths)]) - widths.sum() / 2
        rooms = [
            (float(a), float(b), -height / 2, height / 2) for a, b in itertools.pairwise(edges)
        ]
        for x in edges[1:-1]:
            w, c = door(-height / 2, height / 2)
            walls += _door_wall(float(x), -height / 2, height / 2, w, c, True)
            doors.append((float(x), c))
        bounds = (float(edges[0]), float(edges[-1]), -height / 2, height / 2)
        first, last = rooms[0], rooms[-1]
    gx = float(rng.uniform(last[0] + 0.5, last[1] - 0.5))
    gy = float(rng.uniform(last[2] + 0.5, last[3] - 0.5))
    for _ in range(1000):
        sx = float(rng.uniform(first[0] + 0.2, first[1] - 0.2))
        sy = float(rng.uniform(first[2] + 0.2, first[3] - 0.2))
        psi = float(rng.uniform(-math.pi, math.pi))
        ends = _body_points(sx, sy, psi)
        if (
            ends[:, 0].min() > first[0] + 0.25
            and ends[:, 0].max() < first[1] - 0.25
            and ends[:, 1].min() > first[2] + 0.25
            and ends[:, 1].max() < first[3] - 0.25
        ):
            break
    else:
        raise RuntimeError("no start fits")  # never: a room is 2.5 m or more
    furniture: list[dict[str, Any]] = []
    for x0, x1, y0, y1 in rooms:
        for _ in range(int(rng.integers(0, 3))):
            piece = _rect(
                float(rng.uniform(x0 + 0.6, x1 - 0.6)),
                float(rng.uniform(y0 + 0.6, y1 - 0.6)),
                float(rng.uniform(0.3, 1.0)),
                float(rng.uniform(0.3, 0.8)),
                float(rng.uniform(0, math.pi)),
            )
            ob = obstacle_from_dict(piece)
            goal = np.array([[gx, gy]])
            if (
                all(math.hypot(piece["x"] - dx, piece["y"] - dy) > 1.2 for dx, dy in doors)
                and _body_clearance((sx, sy, psi), ob) > 0.3
                and float(ob.segment_clearance(goal, goal)[0]) > 0.5
            ):
                furniture.append(piece)
    return {
        "start": {"x": sx, "y": sy, "psi": psi},
        "goals": [{"x": gx, "y": gy}],
        "bounds": dict(zip(("xmin", "xmax", "ymin", "ymax"), bounds, strict=True)),
        "obstacles": walls + furniture,
    }


# -- clutter ------------------------------------------------------------------------------------
def _clutter(rng: np.random.Generator) -> Mission:
    """Circles, rotated rectangles and convex polygons in a 10 m x 10 m arena, each kept 0.3 m
    from the others (0.15 m for one in six: gaps are mostly, not all, 0.3 m or more), clear of
    the start's body and round the goal."""
    half = 5.0
    sx, sy, psi = _start_pose(
        rng, float(rng.uniform(-4.3, -3.7)), (-3.5, 3.5), (-half, half, -half, half)
    )
    gx, gy = float(rng.uniform(3.7, 4.3)), float(rng.uniform(-3.5, 3.5))
    target = int(rng.integers(25, 46))
    placed: list[Obstacle] = []
    obstacles: list[dict[str, Any]] = []
    for _ in range(3000):
        if len(obstacles) >= target:
            break
        x, y = (float(v) for v in rng.uniform(-half + 0.4, half - 0.4, size=2))
        kind = rng.random()
        if kind < 0.35:
            spec = _circle(x, y, float(rng.uniform(0.1, 0.4)))
        elif kind < 0.7:
            spec = _rect(
                x,
                y,
                float(rng.uniform(0.15, 1.2)),
                float(rng.uniform(0.1, 0.6)),
                float(rng.uniform(0, math.pi)),
            )
        else:
            k = int(rng.integers(3, 7))
            angles = np.sort(rng.uniform(0, 2 * math.pi, size=k))
            radius = rng.uniform(0.2, 0.5) * rng.uniform(0.7, 1.0, size=k)
            points = [
                [x + r * math.cos(a), y + r * math.sin(a)]
                for a, r in zip(angles, radius, strict=True)
            ]
            try:
                obstacle_from_dict({"type": "polygon", "points": points})
            except ValueError:
                continue  # three points in a line
            hull = spatial.ConvexHull(np.array(points))
            spec = {"type": "polygon", "points": [points[i] for i in hull.vertices]}
        ob = obstacle_from_dict(spec)
        apart = 0.15 if rng.random() < 1 / 6 else 0.3
        g = np.array([[gx, gy]])
        if (
            _body_clearance((sx, sy, psi), ob) > 0.25
            and float(ob.segment_clearance(g, g)[0]) > 0.4
            and all(_obstacle_gap(ob, other) >= apart for other in placed)
        ):
            placed.append(ob)
            obstacles.append(spec)
    return {
        "start": {"x": sx, "y": sy, "psi": psi},
        "goals": [{"x": gx, "y": gy}],
        "bounds": {"xmin": -half, "xmax": half, "ymin": -half, "ymax": half},
        "obstacles": obstacles,
    }


_BUILDERS: dict[str, Callable[[np.random.Generator], Mission]] = {
    "posts": _posts,
    "slots": _slots,
    "pipes": _pipes,
    "rooms": _rooms,
    "clutter": _clutter,
}


def _rounded(value: Any) -> Any:
    """Floats to 0.1 mm (files stay short and diffable); the geometry keeps its meaning."""
    if isinstance(value, float):
        return round(value, 4)
    if isinstance(value, dict):
        return {k: _rounded(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_rounded(v) for v in value]
    return value


def parse_seeds(text: str) -> list[int]:
    """``1000-1199``, ``3``, or ``1,5,7-9``: the seeds named."""
    seeds: list[int] = []
    for part in text.split(","):
        lo, _, hi = part.strip().partition("-")
        first = int(lo)
        last = int(hi) if hi else first
        if last < first:
            raise ValueError(f"seeds: {part!r} runs backwards")
        seeds.extend(range(first, last + 1))
    return seeds


def _histogram(values: Sequence[float], edges: Sequence[float]) -> list[str]:
    counts, _ = np.histogram(values, bins=np.asarray(edges))
    total = max(1, len(values))
    return [
        f"  {lo:4.2f}-{hi:4.2f} m {c:6d} {100 * c / total:5.1f} %"
        for lo, hi, c in zip(edges[:-1], edges[1:], counts, strict=True)
    ]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--family", choices=FAMILIES, required=True)
    parser.add_argument("--seed", type=int, help="the world to write (with --out)")
    parser.add_argument("--seeds", help="several worlds: 1000-1199, 0-9, 1,5,7-9")
    parser.add_argument("--out", type=Path, help="the mission file (a folder with --seeds)")
    parser.add_argument("--known", action="store_true", help="every obstacle known")
    parser.add_argument("--gaps", action="store_true", help="print the posts' gap distribution")
    args = parser.parse_args(argv)
    if (args.seed is None) == (args.seeds is None):
        parser.error("give --seed or --seeds")
    seeds = [args.seed] if args.seed is not None else parse_seeds(args.seeds)
    if args.gaps:
        if args.family != "posts":
            parser.error("--gaps: posts only")
        nearest, delaunay, counts = [], [], []
        for seed in seeds:
            mission = layout("posts", seed)
            gaps = post_gaps(mission)
            nearest.append(gaps["nearest"])
            delaunay.append(gaps["delaunay"])
            counts.append(len(mission["obstacles"]))
        # Edges just below round figures: a gap of three cells is 0.3 m less a rounding error.
        edges = [0, 0.001, 0.1499, 0.2999, 0.4499, 0.5999, 0.7001, 0.8499, 0.9999, 2.0, 10.0]
        print(
            f"posts over {len(seeds)} worlds: {np.mean(counts):.0f} obstacles on average "
            f"({min(counts)}-{max(counts)})"
        )
        print("gap to the nearest post (surface to surface):")
        print("\n".join(_histogram(np.concatenate(nearest).tolist(), edges)))
        print("Delaunay gaps (between neighbouring posts):")
        print("\n".join(_histogram(np.concatenate(delaunay).tolist(), edges)))
        return 0
    for seed in seeds:
        world = generate(args.family, seed, args.known)
        text = json.dumps(world.mission, indent=1) + "\n"
        print(
            f"{world.name}: {world.verdict.label} ({world.verdict.seconds:.1f} s), "
            f"{len(world.mission['obstacles'])} obstacles",
            file=sys.stderr,
        )
        if args.out is None:
            print(text, end="")
        elif args.seeds is not None:
            args.out.mkdir(parents=True, exist_ok=True)
            (args.out / f"{world.name}.json").write_text(text)
        else:
            args.out.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())

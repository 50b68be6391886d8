"""The packed, all-obstacles-at-once geometry answers exactly as the obstacles do one at a time."""

import math

import numpy as np
import pytest

from sim.obstacles import Circle, Obstacle, Polygon, ray_segment_hits, rectangle, unit_vectors
from sim.scene import Scene
from sim.world import WALL, Bounds, World, footprint


def random_obstacles(rng: np.random.Generator, count: int) -> tuple[Obstacle, ...]:
    out: list[Obstacle] = []
    for _ in range(count):
        x, y = rng.uniform(-3, 3, 2)
        kind = rng.integers(3)
        if kind == 0:
            out.append(Circle(x, y, rng.uniform(0.05, 1.0)))
        elif kind == 1:
            w, h = rng.uniform(0.02, 2.0, 2)
            out.append(rectangle(x, y, w, h, rng.uniform(-math.pi, math.pi)))
        else:  # a star-shaped polygon, possibly non-convex
            n = int(rng.integers(3, 8))
            angles = np.sort(rng.uniform(0, 2 * math.pi, n))
            radii = rng.uniform(0.1, 1.5, n)
            pts = tuple(
                (x + r * math.cos(a), y + r * math.sin(a))
                for r, a in zip(radii, angles, strict=True)
            )
            try:
                out.append(Polygon(pts))
            except ValueError:  # degenerate draw (no area): a circle instead
                out.append(Circle(x, y, 0.3))
    return tuple(out)


def random_case(seed: int) -> tuple[World, np.random.Generator]:
    rng = np.random.default_rng(seed)
    world = World(Bounds(-4, 4, -4, 4), random_obstacles(rng, int(rng.integers(0, 9))))
    return world, rng


@pytest.mark.parametrize("seed", range(300))
def test_footprint_queries_equal_the_obstacle_by_obstacle_reference(seed: int) -> None:
    world, rng = random_case(seed)
    pose = np.array([*rng.uniform(-3.5, 3.5, 2), rng.uniform(-math.pi, math.pi)])
    fp = footprint(pose, rng.uniform(-1.2, 1.2, 3))
    # the reference: every obstacle's own segment_clearance, in the obstacles' order
    table = [o.segment_clearance(fp.starts, fp.ends) for o in world.obstacles]
    scene = Scene(world.obstacles)
    if table:
        np.testing.assert_array_equal(
            scene.segment_clearance(fp.starts, fp.ends), np.stack(table, axis=-1)
        )
    ends = np.concatenate([fp.starts, fp.ends])
    gap = float(np.min(world.bounds.wall_clearance(ends) - np.concatenate([fp.radii] * 2)))
    gap = max(min([gap, *(float(np.min(c - fp.radii)) for c in table)]), 0.0)
    assert world.gap(fp) == gap
    for distance in (0.0, 0.01, 0.2, 1.0, gap, float(np.nextafter(gap, np.inf))):
        assert world.free_within(fp, distance) == (distance <= gap)
    walls = world.bounds.wall_clearance(ends) < np.concatenate([fp.radii] * 2)
    first = next((i for i, c in enumerate(table) if np.any(c < fp.radii)), None)
    contact = world.contact(fp)
    if np.any(walls):
        assert contact is not None and contact.obstacle == WALL
    elif first is None:
        assert contact is None
    else:
        assert contact is not None
        assert (contact.obstacle, contact.part) == (first, int(np.argmax(table[first] < fp.radii)))


@pytest.mark.parametrize("seed", range(300))
def test_ray_casts_equal_the_obstacle_by_obstacle_reference(seed: int) -> None:
    world, rng = random_case(seed)
    origin = rng.uniform(-3.5, 3.5, 2)
    dirs = unit_vectors(rng.uniform(-math.pi, math.pi, int(rng.integers(1, 30))))
    reach = float(rng.uniform(0.2, 6.0))
    corners = world.bounds.corners()
    hits = [ray_segment_hits(origin, dirs, corners, np.roll(corners, -1, axis=0)).min(axis=-1)]
    hits += [o.ray_cast(origin, dirs) for o in world.obstacles]
    table = np.stack(hits, axis=-1)
    best = np.argmin(table, axis=-1)
    nearest = table[np.arange(len(dirs)), best]
    what = np.where(nearest <= reach, np.where(best == 0, WALL, best - 1), -2)
    dist, seen = world.ray_cast(origin, dirs, reach)
    np.testing.assert_array_equal(dist, np.minimum(nearest, reach))
    np.testing.assert_array_equal(seen, what)
    if world.obstacles:
        np.testing.assert_array_equal(Scene(world.obstacles).ray_cast(origin, dirs), table[:, 1:])


def test_contact_names_the_first_obstacle_in_order_when_two_touch() -> None:
    # the head touches both: the reference reports obstacle 0, whichever is deeper
    pose = np.array([0.0, 0.0, 0.0])
    fp = footprint(pose, np.zeros(3))
    tip = fp.starts[0]
    world = World(obstacles=(Circle(tip[0] - 0.05, 0.06, 0.05), Circle(tip[0] - 0.02, 0.0, 0.1)))
    contact = world.contact(fp)
    assert contact is not None and (contact.obstacle, contact.part) == (0, 0)

"""Thousands of obstacles: a scene's bucket index finds the same nearby obstacles as testing
every box, and the simulator's per-step questions answer the same with it as without."""

from __future__ import annotations

import numpy as np
import pytest

from sim import scene as scene_module
from sim.obstacles import Circle, Obstacle, rectangle
from sim.scene import Scene
from sim.world import Bounds, World, footprint


def field(n: int, seed: int = 0) -> tuple[Obstacle, ...]:
    rng = np.random.default_rng(seed)
    out: list[Obstacle] = []
    for x, y in rng.uniform(-20, 20, (n, 2)):
        if rng.random() < 0.7:
            out.append(Circle(float(x), float(y), float(rng.uniform(0.05, 0.3))))
        else:
            out.append(rectangle(float(x), float(y), 0.4, 0.2, float(rng.uniform(0, 3))))
    out.append(rectangle(0.0, 19.5, 40.0, 0.2))  # a long wall: kept apart, always tested
    return tuple(out)


def test_the_index_finds_what_testing_every_box_finds() -> None:
    obstacles = field(3000)
    indexed = Scene(obstacles)
    assert indexed.index is not None and indexed.index.big.size == 1
    b = indexed.boxes
    rng = np.random.default_rng(1)
    for _ in range(300):
        lo = rng.uniform(-22, 22, 2)
        hi = lo + rng.uniform(0, 2, 2)
        margin = float(rng.uniform(0, 1.5))
        close = (
            (b[:, 0] <= hi[0] + margin)
            & (b[:, 2] >= lo[0] - margin)
            & (b[:, 1] <= hi[1] + margin)
            & (b[:, 3] >= lo[1] - margin)
        )
        assert indexed.near(lo, hi, margin).tolist() == np.flatnonzero(close).tolist()


def test_collisions_and_gaps_are_the_same_with_and_without_the_index(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    obstacles = field(2500, seed=2)
    with_index = World(Bounds(-21, 21, -21, 21), obstacles)
    assert with_index._everything[0].index is not None  # (packed now, before the patch)
    monkeypatch.setattr(scene_module, "INDEX_MIN", 10**9)
    without = World(Bounds(-21, 21, -21, 21), obstacles)
    assert without._everything[0].index is None
    rng = np.random.default_rng(3)
    for _ in range(300):
        pose = np.array([*rng.uniform(-20, 20, 2), rng.uniform(-3, 3)])
        fp = footprint(pose, np.zeros(3))
        distance = float(rng.uniform(0, 0.3))
        assert with_index.free_within(fp, distance) == without.free_within(fp, distance)
        assert with_index.contact(fp) == without.contact(fp)

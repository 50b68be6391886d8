"""The compiled footprint gap decides ``free_within`` as the numpy path does, at the boundary too."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim import collision_kernel
from sim.obstacles import unit_vectors
from sim.world import World, footprint
from tests.sim.test_scene import random_case

pytestmark = pytest.mark.skipif(not collision_kernel.AVAILABLE, reason="numba kernels are off")


@pytest.mark.parametrize("seed", range(200))
def test_free_within_compiled_equals_numpy(seed: int, monkeypatch: pytest.MonkeyPatch) -> None:
    world, rng = random_case(seed)
    pose = np.array([*rng.uniform(-3.5, 3.5, 2), rng.uniform(-math.pi, math.pi)])
    fp = footprint(pose, rng.uniform(-1.2, 1.2, 3))
    gap = world.gap(fp)
    distances = (0.0, 0.01, 0.2, 1.0, 3.0, gap, float(np.nextafter(gap, np.inf)))
    compiled = [world.free_within(fp, d) for d in distances]
    monkeypatch.setattr(collision_kernel, "AVAILABLE", False)
    reference = [World.free_within(world, fp, d) for d in distances]
    assert compiled == reference
    assert compiled[-2] and not compiled[-1]  # exactly the gap is free, a hair more is not


@pytest.mark.parametrize("seed", range(200))
def test_ray_cast_compiled_equals_numpy(seed: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """The same distances and the same things hit, from anywhere (inside obstacles too), for
    ranges that leave walls and obstacles out."""
    world, rng = random_case(seed)
    origin = rng.uniform(-4.2, 4.2, 2)
    dirs = unit_vectors(rng.uniform(-math.pi, math.pi, int(rng.integers(1, 12))))
    reach = float(rng.choice([0.3, 0.8, 1.5, 20.0]))
    dist, what = world.ray_cast(origin, dirs, reach)
    monkeypatch.setattr(collision_kernel, "AVAILABLE", False)
    ref_dist, ref_what = world.ray_cast(origin, dirs, reach)
    assert np.array_equal(dist, ref_dist)
    assert np.array_equal(what, ref_what)

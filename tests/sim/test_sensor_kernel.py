"""The compiled sensor read (rays cast and reduced per sensor in one call) reads what the numpy
path reads: the same ranges, the same things hit, the same noise drawn in the same order."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim import collision_kernel
from sim.obstacles import Circle
from sim.scene import Scene
from sim.sensors import RangeSensor, SensorSuite, range_ring
from tests.sim.test_scene import random_case

pytestmark = pytest.mark.skipif(not collision_kernel.AVAILABLE, reason="numba kernels are off")


def suite(rng: np.random.Generator) -> SensorSuite:
    noise = float(rng.choice([0.0, 0.01, 0.05]))
    ir = RangeSensor("ir", 0.0, float(rng.choice([0.3, 0.8, 2.0])), math.radians(10), 3, noise)
    ring = range_ring(int(rng.integers(1, 9)), float(rng.choice([0.5, 1.5, 20.0])), noise)
    return SensorSuite((ir, *ring), joint_noise_std=float(rng.choice([0.0, 0.01])))


@pytest.mark.parametrize("seed", range(120))
def test_compiled_read_equals_numpy(seed: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """Along a short random walk (the candidate obstacles kept between nearby reads, found
    anew after a jump), from anywhere, inside obstacles too."""
    world, rng = random_case(seed)
    compiled = suite(rng)
    reference = SensorSuite(compiled.range_sensors, joint_noise_std=compiled.joint_noise_std)
    compiled.seed(seed)
    reference.seed(seed)
    pose = np.array([*rng.uniform(-4.2, 4.2, 2), rng.uniform(-math.pi, math.pi)])
    joints = rng.uniform(-1.2, 1.2, 3)
    for step in range(12):
        if step == 6:  # a jump: the cached candidates no longer cover the origin
            pose[:2] = rng.uniform(-4.2, 4.2, 2)
        pose += np.array([*rng.normal(0, 0.04, 2), rng.normal(0, 0.2)])
        dropped = frozenset({"ring0"}) if step % 5 == 4 else frozenset()
        got = compiled.read(world, pose, joints, dropped)
        with monkeypatch.context() as m:
            m.setattr(collision_kernel, "AVAILABLE", False)
            want = reference.read(world, pose, joints, dropped)
        assert got.origin == want.origin
        assert got.hits == want.hits
        assert list(got.ranges) == list(want.ranges)
        for name, value in want.ranges.items():
            assert got.ranges[name] == value or (math.isnan(value) and math.isnan(got.ranges[name]))
        np.testing.assert_array_equal(got.joints, want.joints)
        np.testing.assert_array_equal(got.pose, want.pose)


@pytest.mark.parametrize("seed", range(40))
def test_circle_distances_equal_numpy(seed: int) -> None:
    """The compiled rest of ``circle_ray_cast`` after numpy's products, inside circles too."""
    rng = np.random.default_rng(seed)
    circles = [
        Circle(float(x), float(y), float(r))
        for x, y, r in zip(
            rng.uniform(-3, 3, 6), rng.uniform(-3, 3, 6), rng.uniform(0.05, 0.8, 6), strict=True
        )
    ]
    scene = Scene(circles)
    origin = rng.uniform(-4.2, 4.2, 2)
    if seed % 3 == 0:  # from a circle's centre
        origin = scene.centres[0].copy()
    angles = rng.uniform(-math.pi, math.pi, int(rng.integers(1, 14)))
    dirs = np.stack([np.cos(angles), np.sin(angles)], axis=-1)
    bq, rr = scene.circle_products(origin, dirs)
    got = collision_kernel.circle_distances(bq, rr, scene.radii)
    np.testing.assert_array_equal(got, scene.circle_ray_cast(origin, dirs))

"""The per-step shortcuts give the general code's numbers: the body chain, one control's
validation and clamp, the remembered twists."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.controls import FixedShape, as_batch, clamp_joints
from sim.robot import DEFAULT_GEOMETRY, body_chain, body_twist, head_tip, joint_positions
from sim.simulator import Simulator
from sim.world import footprint, footprint_of_chain


@pytest.mark.parametrize("seed", range(5))
def test_body_chain_is_head_tip_and_joint_positions(seed: int) -> None:
    rng = np.random.default_rng(seed)
    for _ in range(200):
        pose = np.array([*rng.uniform(-8, 8, 2), rng.uniform(-2 * math.pi, 2 * math.pi)])
        phi = rng.uniform(-1.5, 1.5, 3)
        chain = body_chain(pose, phi, DEFAULT_GEOMETRY)
        np.testing.assert_array_equal(chain[1:], joint_positions(pose, phi))
        np.testing.assert_array_equal(chain[0], head_tip(pose))
        fp, ref = footprint_of_chain(chain), footprint(pose, phi)
        np.testing.assert_array_equal(fp.starts, ref.starts)
        np.testing.assert_array_equal(fp.ends, ref.ends)
        np.testing.assert_array_equal(fp.radii, ref.radii)


def test_one_control_is_built_as_a_batch_of_one() -> None:
    """The same arrays as the batched path (limits and clamp included), and its errors."""
    rng = np.random.default_rng(7)
    m = DEFAULT_GEOMETRY.max_joint_angle
    for _ in range(500):
        theta = rng.uniform(-1.0, 1.0, 4)
        joints = rng.uniform(-math.pi / 2, math.pi / 2, 3)
        joints[rng.integers(3)] = rng.choice([m, -m, math.pi / 2, -math.pi / 2, 0.0])
        for t, j in ((theta, joints), (list(theta), tuple(joints))):
            control = FixedShape.of(t, j)
            np.testing.assert_array_equal(control.theta, as_batch(theta, 4, "theta"))
            want = np.clip(as_batch(joints, 3, "joints"), -m, m)
            np.testing.assert_array_equal(control.joints, want)
            assert control.theta.shape == (1, 4) and control.joints.shape == (1, 3)
    for theta, joints, field in (
        (np.array([1.5, 0, 0, 0]), np.zeros(3), "theta"),
        (np.zeros(4), np.array([0.0, 2.0, 0.0]), "joints"),
        (np.array([math.nan, 0, 0, 0]), np.zeros(3), "theta"),
        ([0.0, 0.0, 0.0], np.zeros(3), "theta"),
    ):
        with pytest.raises(ValueError, match=field):
            FixedShape.of(theta, joints)


def test_clamp_is_np_clip() -> None:
    rng = np.random.default_rng(3)
    m = DEFAULT_GEOMETRY.max_joint_angle
    phi = rng.uniform(-2.0, 2.0, (50, 3))
    phi[0] = [m, -m, -0.0]
    np.testing.assert_array_equal(clamp_joints(phi, DEFAULT_GEOMETRY), np.clip(phi, -m, m))


def test_remembered_twists_are_body_twist() -> None:
    sim = Simulator()
    rng = np.random.default_rng(5)
    pairs = [(rng.uniform(-1, 1, 4), rng.uniform(-1.2, 1.2, 3)) for _ in range(6)]
    for k in range(60):  # each pair met again and again, in a shuffled order
        theta, phi = pairs[int(rng.integers(len(pairs)))] if k >= 6 else pairs[k]
        np.testing.assert_array_equal(sim._twist(theta, phi, None), body_twist(theta, phi))


def test_a_held_shape_under_new_screw_speeds_moves_as_body_twist_says() -> None:
    """Steering changes the screw speeds under a shape it holds: the simulator reuses the
    shape's solver, and each twist is ``body_twist``'s, float for float (shapes past the clamp
    too)."""
    sim = Simulator()
    rng = np.random.default_rng(6)
    shapes = [rng.uniform(-3.0, 3.0, 3) for _ in range(3)]
    for k in range(90):
        phi, theta = shapes[k % 3], rng.uniform(-5, 5, 4)
        np.testing.assert_array_equal(sim._twist(theta, phi, None), body_twist(theta, phi))
    assert len(sim._solvers) == 3

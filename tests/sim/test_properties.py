"""Physical properties of the model that any user can check by hand."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim.controls import FixedShape, PeriodicGait
from sim.robot import body_twist
from sim.rollout import RolloutConfig, rollout

speed = st.floats(-1, 1)
theta4 = st.tuples(speed, speed, speed, speed)
joint = st.floats(-(np.pi / 2 - 0.05), np.pi / 2 - 0.05)
shape3 = st.tuples(joint, joint, joint)


@settings(max_examples=60, deadline=None)
@given(theta4, shape3, st.floats(-3, 3))
def test_twist_is_linear_in_screw_speeds(theta, phi, scale) -> None:
    t, p = np.array(theta), np.array(phi)
    base = body_twist(t, p)
    np.testing.assert_allclose(body_twist(-t, p), -base, atol=1e-12)
    np.testing.assert_allclose(body_twist(scale * t, p), scale * base, atol=1e-12)


def test_fighting_screws_do_not_move_a_straight_body() -> None:
    end = rollout(FixedShape.of([1, -1, -1, 1], [0, 0, 0])).end[0]
    np.testing.assert_allclose(end[:3], 0.0, atol=1e-12)


@pytest.mark.parametrize(
    ("theta", "direction"),
    [
        ((-1, 1, -1, 1), (-1, 0)),
        ((1, -1, 1, -1), (1, 0)),
        ((1, 1, 1, 1), (0, -1)),
        ((-1, -1, -1, -1), (0, 1)),
    ],
)
def test_straight_body_is_omnidirectional(theta, direction) -> None:
    # docs/robot-model.md ("Primitive directions"): 7.5 m per rollout forward, backward and sideways.
    end = rollout(FixedShape.of(theta, [0, 0, 0])).end[0]
    np.testing.assert_allclose(end[:2], 7.5 * np.array(direction), atol=1e-9)
    assert end[2] == pytest.approx(0.0, abs=1e-12)


@settings(max_examples=60, deadline=None)
@given(
    theta4,
    shape3,
    st.tuples(st.floats(-np.pi, np.pi), st.floats(-np.pi, np.pi), st.floats(-np.pi, np.pi)),
)
def test_states_stay_finite_within_limits(theta, phi, phases) -> None:
    for control in (FixedShape.of(theta, phi), PeriodicGait.of(theta, phases)):
        states = rollout(control, config=RolloutConfig(duration=50, dt=1)).states
        assert np.all(np.isfinite(states))


@settings(max_examples=60, deadline=None)
@given(theta4, st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1)))
def test_speed_is_bounded_within_the_learning_clamp(theta, phi) -> None:
    # Inside ±1 rad, σ_min/σ_max of A_b stays >= 0.054 (docs/robot-model.md, "Solving"), so |v| stays small.
    # Beyond it the least-squares speed can blow up near singular shapes such as (0, 1.5, -1.5).
    states = rollout(FixedShape.of(theta, phi), config=RolloutConfig(duration=10)).states[0]
    assert np.all(np.linalg.norm(np.diff(states[:, :2], axis=0), axis=-1) < 0.5)


def test_singular_corner_shape_is_clamped_and_finite() -> None:
    half_pi = np.pi / 2
    end = rollout(FixedShape.of([1, 1, 1, 1], [half_pi, -half_pi, half_pi])).end
    assert np.all(np.isfinite(end))


@settings(max_examples=50, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from(["full", "rank2", "tiny"]))
def test_least_squares_equals_lstsq(seed, kind) -> None:
    from sim.robot import least_squares

    rng = np.random.default_rng(seed)
    a = rng.normal(size=(4, 3))
    if kind == "rank2":  # all axles parallel: the singular corner shapes
        a[:, 2] = a[:, 0] * 0.7 - a[:, 1] * 0.2
    elif kind == "tiny":
        a[:, 2] *= 1e-5
    b = rng.normal(size=4)
    expected = np.linalg.lstsq(a, b, rcond=1e-6)[0]
    got = least_squares((a[:, 0], a[:, 1], a[:, 2]), b, 1e-6)
    np.testing.assert_allclose(got, expected, atol=1e-8 * max(1.0, np.abs(expected).max()))

"""The compiled (numba) and numpy rollout kernels give the same states, and the setting picks."""

import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import sim
from sim.controls import FixedShape, PeriodicGait
from sim.kernel_setting import KERNEL_SETTING
from sim.reference import reference_rollout
from sim.robot import DEFAULT_GEOMETRY, WELL_CONDITIONED, RobotGeometry
from sim.rollout import RolloutConfig, compiled_kernels, rollout

speed = st.floats(-1, 1)
joint = st.floats(-1.57, 1.57)  # past the clamp too: FixedShape clamps, both kernels see the same
phase = st.floats(-np.pi, np.pi)
pose = st.tuples(st.floats(-5, 5), st.floats(-5, 5), st.floats(-np.pi, np.pi))
speeds = st.lists(st.tuples(speed, speed, speed, speed), min_size=1, max_size=6)
modes = st.sampled_from(["paper", "complete"])


def both(control, start, config, geometry=DEFAULT_GEOMETRY):
    compiled = rollout(control, start, config, geometry, kernel="numba")
    plain = rollout(control, start, config, geometry, kernel="numpy")
    np.testing.assert_array_equal(compiled.times, plain.times)
    return compiled.states, plain.states


@settings(max_examples=40, deadline=None)
@given(speeds, st.tuples(joint, joint, joint), pose, st.sampled_from([1.0, 0.3]), modes)
def test_fixed_shapes_same_in_both_kernels(thetas, phi, start, dt, mode) -> None:
    control = FixedShape.of(thetas, phi)
    compiled, plain = both(control, start, RolloutConfig(20.0, dt, mode))
    assert compiled.shape == (len(thetas), round(20.0 / dt) + 1, 6)
    np.testing.assert_allclose(compiled, plain, atol=1e-9, rtol=0)


@settings(max_examples=40, deadline=None)
@given(
    speeds,
    st.tuples(phase, phase, phase),
    pose,
    st.floats(0, 1.5),
    st.floats(-3, 3),
    st.floats(-10, 10),
    modes,
)
def test_gaits_same_in_both_kernels(thetas, phases, start, amplitude, omega, t0, mode) -> None:
    control = PeriodicGait.of(thetas, phases, amplitude, omega, t0)
    compiled, plain = both(control, start, RolloutConfig(15.0, 0.25, mode))
    np.testing.assert_allclose(compiled, plain, atol=1e-9, rtol=0)


@settings(max_examples=20, deadline=None)
@given(speeds, st.tuples(phase, phase, phase), st.floats(-5, 5), st.floats(0, 12), modes)
def test_a_stopped_gait_holds_its_joints_in_both_kernels(thetas, phases, t0, run, mode) -> None:
    """A gait with ``t_end`` holds φ(t_end) from there on, its joints still (both kernels)."""
    control = PeriodicGait.of(thetas, phases, t0=t0, t_end=t0 + run)
    compiled, plain = both(control, (0.0, 0.0, 0.0), RolloutConfig(15.0, 0.25, mode))
    np.testing.assert_allclose(compiled, plain, atol=1e-9, rtol=0)
    times = RolloutConfig(15.0, 0.25).times()
    held = times >= t0 + run
    want = control.angles(np.array([t0 + run]))[:, 0, :]
    np.testing.assert_allclose(
        compiled[:, held, 3:],
        np.broadcast_to(want[:, None], compiled[:, held, 3:].shape),
        atol=1e-12,
    )
    assert np.all(control.rates(times)[:, held] == 0.0)


@settings(max_examples=15, deadline=None)
@given(speeds, st.tuples(phase, phase, phase), pose, modes)
def test_numpy_kernel_matches_reference(thetas, phases, start, mode) -> None:
    # test_batched_vs_reference checks the default kernel; this keeps the fallback honest too.
    control = PeriodicGait.of(thetas, phases)
    states = rollout(control, start, RolloutConfig(20.0, 0.5, mode), kernel="numpy").states
    ph = np.array(phases)
    for k, theta in enumerate(thetas):
        ref = reference_rollout(
            theta,
            lambda t: 0.2 * np.sin(0.6 * t + ph),
            (lambda t: 0.12 * np.cos(0.6 * t + ph)) if mode == "complete" else None,
            start,
            20.0,
            0.5,
        )
        np.testing.assert_allclose(states[k], ref, atol=1e-9, rtol=0)


def test_other_geometry_same_in_both_kernels() -> None:
    geometry = RobotGeometry(
        screw_radius=0.05, front_length=0.09, rear_length=0.15, head_offset=0.1
    )
    rng = np.random.default_rng(3)
    control = PeriodicGait.of(rng.uniform(-1, 1, (5, 4)), rng.uniform(-3, 3, (5, 3)))
    compiled, plain = both(
        control, (0.5, -0.5, 1.0), RolloutConfig(joint_mode="complete"), geometry
    )
    np.testing.assert_allclose(compiled, plain, atol=1e-9, rtol=0)
    default, _ = both(control, (0.5, -0.5, 1.0), RolloutConfig(joint_mode="complete"))
    assert np.abs(default[:, -1, :2] - compiled[:, -1, :2]).max() > 1e-3  # geometry was used


def test_a_batch_equals_its_rollouts_one_at_a_time() -> None:
    rng = np.random.default_rng(7)
    control = PeriodicGait.of(rng.uniform(-1, 1, (9, 4)), rng.uniform(-3, 3, (9, 3)))
    starts = rng.uniform(-1, 1, (9, 3))
    config = RolloutConfig(joint_mode="complete")
    batch = rollout(control, starts, config, kernel="numba").states
    for k in range(9):
        one = PeriodicGait.of(control.theta[k], control.phases[k])
        np.testing.assert_array_equal(
            rollout(one, starts[k], config, kernel="numba").states[0], batch[k]
        )


def test_non_contiguous_and_integer_inputs() -> None:
    theta = np.array([[1, 0, -1, 0, 1, 1, 0, 0]], dtype=np.int64)[:, ::2]  # strided ints
    control = FixedShape(theta, np.zeros((1, 3), dtype=np.float32))  # unvalidated constructor
    compiled, plain = both(control, (0, 0, 0), RolloutConfig(duration=10.0))
    np.testing.assert_allclose(compiled, plain, atol=1e-12, rtol=0)


def test_singular_corner_shape_same_in_both_kernels() -> None:
    half_pi = np.pi / 2
    control = FixedShape.of([[1, 1, 1, 1], [1, -1, 0.5, 0]], [half_pi, -half_pi, half_pi])
    compiled, plain = both(control, (0, 0, 0), RolloutConfig(duration=10.0))
    assert np.all(np.isfinite(compiled))
    np.testing.assert_allclose(compiled, plain, atol=1e-9, rtol=0)


@settings(max_examples=50, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from(["full", "rank2", "tiny"]))
def test_compiled_least_squares_equals_lstsq(seed, kind) -> None:
    kernels = compiled_kernels("numba")
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(4, 3))
    if kind == "rank2":  # all axles parallel: the singular corner shapes take the SVD
        a[:, 2] = a[:, 0] * 0.7 - a[:, 1] * 0.2
    elif kind == "tiny":
        a[:, 2] *= 1e-5
    b = rng.normal(size=4)
    expected = np.linalg.lstsq(a, b, rcond=1e-6)[0]
    got = np.array(kernels.lstsq_rows(a, b, 1e-6, WELL_CONDITIONED))
    np.testing.assert_allclose(got, expected, atol=1e-8 * max(1.0, np.abs(expected).max()))


def test_setting_picks_the_kernel(monkeypatch) -> None:
    monkeypatch.setenv(KERNEL_SETTING, "numpy")
    assert compiled_kernels() is None
    monkeypatch.setenv(KERNEL_SETTING, "NUMBA")
    assert compiled_kernels() is not None
    monkeypatch.delenv(KERNEL_SETTING)
    assert compiled_kernels() is not None  # auto, numba installed
    assert compiled_kernels("numpy") is None  # the argument wins over the setting


def test_bad_setting_is_named(monkeypatch) -> None:
    monkeypatch.setenv(KERNEL_SETTING, "fortran")
    control = FixedShape.of([1, 0, 0, 0], [0, 0, 0])
    with pytest.raises(ValueError, match=KERNEL_SETTING):
        rollout(control)
    with pytest.raises(ValueError, match="kernel"):
        rollout(control, kernel="fortran")  # type: ignore[arg-type]


def hide_numba_kernels(monkeypatch) -> None:
    """Make ``from sim import kernels`` raise ImportError, as on a machine without numba."""
    monkeypatch.setitem(sys.modules, "sim.kernels", None)
    monkeypatch.delattr(sim, "kernels", raising=False)


def test_without_numba_auto_falls_back_to_numpy(monkeypatch) -> None:
    hide_numba_kernels(monkeypatch)
    assert compiled_kernels("auto") is None
    control = PeriodicGait.of([[0.5, -0.2, 0.3, 1.0]], [[0.1, 0.2, 0.3]])
    monkeypatch.setenv(KERNEL_SETTING, "auto")
    states = rollout(control).states
    monkeypatch.undo()
    np.testing.assert_allclose(states, rollout(control, kernel="numba").states, atol=1e-9)
    hide_numba_kernels(monkeypatch)
    with pytest.raises(ImportError):
        compiled_kernels("numba")

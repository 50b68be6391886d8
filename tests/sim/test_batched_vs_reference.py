"""The batched simulator equals the scalar reference (sim/reference.py, docs/robot-model.md) to 1e-9."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from sim.controls import FixedShape, PeriodicGait
from sim.reference import reference_rollout
from sim.rollout import RolloutConfig, rollout

speed = st.floats(-1, 1)
joint = st.floats(-1.5, 1.5)
phase = st.floats(-np.pi, np.pi)
pose = st.tuples(st.floats(-5, 5), st.floats(-5, 5), st.floats(-np.pi, np.pi))
speeds = st.lists(st.tuples(speed, speed, speed, speed), min_size=1, max_size=5)


@settings(max_examples=40, deadline=None)
@given(speeds, st.tuples(joint, joint, joint), pose, st.sampled_from([1.0, 0.5]))
def test_fixed_shapes_match_reference(thetas, phi, start, dt) -> None:
    control = FixedShape.of(thetas, phi)
    config = RolloutConfig(duration=20.0, dt=dt)
    batched = rollout(control, start, config).states
    for k, theta in enumerate(thetas):
        ref = reference_rollout(theta, lambda t: control.joints[0], None, start, 20.0, dt)
        np.testing.assert_allclose(batched[k], ref, atol=1e-9, rtol=0)


@settings(max_examples=30, deadline=None)
@given(speeds, st.tuples(phase, phase, phase), pose, st.sampled_from(["paper", "complete"]))
def test_periodic_gaits_match_reference(thetas, phases, start, mode) -> None:
    control = PeriodicGait.of(thetas, phases)
    config = RolloutConfig(duration=30.0, dt=0.5, joint_mode=mode)
    batched = rollout(control, start, config).states
    ph = np.array(phases)

    def angles(t: float) -> np.ndarray:
        return 0.2 * np.sin(0.6 * t + ph)

    def rates(t: float) -> np.ndarray:
        return 0.12 * np.cos(0.6 * t + ph)

    for k, theta in enumerate(thetas):
        ref = reference_rollout(
            theta, angles, rates if mode == "complete" else None, start, 30.0, 0.5
        )
        np.testing.assert_allclose(batched[k], ref, atol=1e-9, rtol=0)

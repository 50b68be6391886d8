"""Rollouts per second: batched simulator vs the scalar reference (DESIGN §8: >= 50x).

K = 40 rollouts x 100 steps, the size of one PI² update. Prints figures, never asserts.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from sim.controls import Control, FixedShape, PeriodicGait
from sim.reference import reference_rollout
from sim.rollout import RolloutConfig, rollout

K = 40
Factory = Callable[[int], Callable[[float], np.ndarray]]


def best_of(fn: Callable[[], object], repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    rng = np.random.default_rng(0)
    theta = rng.uniform(-1, 1, (K, 4))
    joints = rng.uniform(-1, 1, (K, 3))
    phases = rng.uniform(-np.pi, np.pi, (K, 3))
    print(f"K = {K} rollouts x 100 steps (dt = 1, T = 100), best of several runs")
    print(
        f"{'case':<28}{'batched [ms]':>14}{'reference [ms]':>16}{'rollouts/s':>14}{'ratio':>9}{'max |diff|':>13}"
    )
    cases = [
        ("fixed shape (U1/U2)", FixedShape.of(theta, joints), lambda k: lambda t: joints[k], None),
        (
            "periodic gait (U3)",
            PeriodicGait.of(theta, phases),
            lambda k: lambda t: 0.2 * np.sin(0.6 * t + phases[k]),
            None,
        ),
        (
            "periodic, complete mode",
            PeriodicGait.of(theta, phases),
            lambda k: lambda t: 0.2 * np.sin(0.6 * t + phases[k]),
            lambda k: lambda t: 0.12 * np.cos(0.6 * t + phases[k]),
        ),
    ]
    for name, control, angles, rates in cases:
        measure(name, control, theta, angles, rates)


def measure(
    name: str, control: Control, theta: np.ndarray, angles: Factory, rates: Factory | None
) -> None:
    config = RolloutConfig(joint_mode="complete" if rates else "paper")
    batched_states = rollout(control, config=config).states

    def reference() -> np.ndarray:
        return np.stack(
            [reference_rollout(theta[k], angles(k), rates(k) if rates else None) for k in range(K)]
        )

    diff = float(np.abs(reference() - batched_states).max())
    tb = best_of(lambda: rollout(control, config=config), 50)
    tr = best_of(reference, 3)
    print(
        f"{name:<28}{tb * 1e3:>14.3f}{tr * 1e3:>16.1f}{K / tb:>14.0f}{tr / tb:>8.0f}x{diff:>13.1e}"
    )


if __name__ == "__main__":
    main()

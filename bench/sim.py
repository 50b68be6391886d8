"""Rollouts per second: batched simulator (numba and numpy kernels) vs the scalar reference.

Part 1: K = 40 rollouts x 100 steps (one PI² update) for every control kind, batched vs the
scalar reference ``sim/reference.py`` measured in turns in the same run (issue #15 target:
>= 100x). Part 2: rollouts/s vs K from 1 to 10,000. Part 3: numba's compile time, paid once
per machine (``cache=True``), measured in a fresh process with an empty cache, and the cost of
loading the cached code in a new process; both are left out of the ratios. ``--load`` keeps the
other core busy (a spinning child process) meanwhile. A fixed pure-Python workload is timed
beside the figures so runs on a loaded or quiet machine can be compared. Prints, never asserts.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import numpy as np

from sim.controls import Control, FixedShape, PeriodicGait
from sim.reference import JointFunction, reference_rollout
from sim.rollout import Kernel, RolloutConfig, compiled_kernels, rollout

K = 40
SIZES = (1, 10, 100, 1_000, 10_000)
KERNELS: tuple[Kernel, ...] = ("numba", "numpy")


@dataclass(frozen=True)
class Case:
    """One control kind: its batch, and the reference's joint functions for rollout ``k``."""

    name: str
    control: Control
    config: RolloutConfig
    angles: Callable[[int], JointFunction]
    rates: Callable[[int], JointFunction] | None


def cases(size: int, seed: int = 0) -> list[Case]:
    """The three control kinds, ``size`` rollouts each, drawn with ``seed``."""
    rng = np.random.default_rng(seed)
    theta = rng.uniform(-1, 1, (size, 4))
    joints = rng.uniform(-1, 1, (size, 3))
    phases = rng.uniform(-np.pi, np.pi, (size, 3))
    gait = PeriodicGait.of(theta, phases)
    fixed = FixedShape.of(theta, joints)
    a, w = gait.amplitude, gait.omega

    def held(k: int) -> JointFunction:
        return lambda t: fixed.joints[k]

    def angles(k: int) -> JointFunction:
        return lambda t: a * np.sin(w * t + phases[k])

    def rates(k: int) -> JointFunction:
        return lambda t: a * w * np.cos(w * t + phases[k])

    return [
        Case("fixed shape (U1/U2)", fixed, RolloutConfig(), held, None),
        Case("periodic gait (U3)", gait, RolloutConfig(), angles, None),
        Case("gait, complete mode", gait, RolloutConfig(joint_mode="complete"), angles, rates),
    ]


@dataclass(frozen=True)
class Timing:
    """Best wall and best CPU (this process) seconds of one call."""

    wall: float
    cpu: float

    def better(self, other: Timing) -> Timing:
        return Timing(min(self.wall, other.wall), min(self.cpu, other.cpu))


NEVER = Timing(float("inf"), float("inf"))


def best_time(fn: Callable[[], object], repeat: int, budget: float = 0.3) -> Timing:
    """Best times of ``fn`` over at least ``repeat`` runs (more while under ``budget`` s).

    CPU time is what the ratios use: on a shared machine a long call (the reference) is
    preempted more often than a short one, which wall-clock best-of would count against it."""
    best, spent, runs = NEVER, 0.0, 0
    while runs < repeat or spent < budget:
        w0, c0 = time.perf_counter(), time.process_time()
        fn()
        wall, cpu = time.perf_counter() - w0, time.process_time() - c0
        best, spent, runs = best.better(Timing(wall, cpu)), spent + wall, runs + 1
        if runs >= 1000:
            break
    return best


def reference_states(case: Case) -> np.ndarray:
    theta = case.control.theta
    return np.stack(
        [
            reference_rollout(theta[k], case.angles(k), case.rates(k) if case.rates else None)
            for k in range(case.control.size)
        ]
    )


def calibration() -> float:
    """Seconds for a fixed pure-Python workload (best of 5): the machine's speed in this run."""

    def work() -> float:
        total = 0.0
        for i in range(200_000):
            total += i * 0.5
        return total

    return best_time(work, 5, budget=0.0).cpu


def ratios(rounds: int) -> None:
    print(f"Part 1: K = {K} rollouts x 100 steps (dt = 1, T = 100); batched and reference timed")
    print(f"in turns, {rounds} rounds, best of each; ratio = reference time / batched time, on CPU")
    print(
        "time (wall-clock ratio beside it); numba compiled or loaded beforehand (Part 3), not timed"
    )
    print(
        f"{'case':<22}{'kernel':<7}{'batched [ms]':>13}{'ref [ms]':>10}{'rollouts/s':>12}"
        f"{'ratio':>8}{'wall':>8}{'max |diff|':>12}"
    )
    for case in cases(K):
        ref = reference_states(case)
        best = dict.fromkeys(KERNELS, NEVER)
        tr = NEVER
        for _ in range(rounds):  # interleaved, so a burst of load hits both sides alike
            for kernel in KERNELS:
                run = partial(rollout, case.control, config=case.config, kernel=kernel)
                best[kernel] = best[kernel].better(best_time(run, 20, budget=0.05))
            tr = tr.better(best_time(partial(reference_states, case), 1, budget=0.0))
        for kernel in KERNELS:
            states = rollout(case.control, config=case.config, kernel=kernel).states
            diff = float(np.abs(states - ref).max())
            tb = best[kernel]
            print(
                f"{case.name:<22}{kernel:<7}{tb.cpu * 1e3:>13.3f}{tr.cpu * 1e3:>10.1f}"
                f"{K / tb.cpu:>12.0f}{tr.cpu / tb.cpu:>7.0f}x{tr.wall / tb.wall:>7.0f}x{diff:>12.1e}"
            )


def scaling() -> None:
    print("\nPart 2: rollouts/s (CPU time) vs K, 100 steps each; reference: one at a time")
    header = "".join(f"{'K=' + str(k):>11}" for k in SIZES)
    print(f"{'case':<22}{'kernel':<10}{header}")
    for index, name in enumerate(c.name for c in cases(1)):
        row: dict[str, list[float]] = {kernel: [] for kernel in KERNELS}
        for size in SIZES:
            case = cases(size)[index]
            for kernel in KERNELS:
                run = partial(rollout, case.control, config=case.config, kernel=kernel)
                row[kernel].append(size / best_time(run, 3, budget=0.2).cpu)
        ref_case = cases(4)[index]
        ref_rate = 4 / best_time(partial(reference_states, ref_case), 3, budget=0.0).cpu
        for kernel in KERNELS:
            print(f"{name:<22}{kernel:<10}" + "".join(f"{r:>11.0f}" for r in row[kernel]))
        print(f"{name:<22}{'reference':<10}" + f"{ref_rate:>11.0f}" * len(SIZES))


FIRST_CALLS = """
import time
t0 = time.perf_counter()
from bench.sim import cases
from sim.rollout import rollout
for case in cases(2):
    rollout(case.control, config=case.config, kernel="numba")
print(time.perf_counter() - t0)
"""


def compile_time() -> None:
    print("\nPart 3: numba, first calls in a new process (every kernel, both joint modes)")
    with tempfile.TemporaryDirectory(prefix="screwsnake-numba-") as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache}
        for label in ("empty cache: compile", "cache filled: load"):
            out = subprocess.run(
                [sys.executable, "-c", FIRST_CALLS],
                env=env,
                capture_output=True,
                text=True,
                check=True,
            )
            print(f"  {label:<24}{float(out.stdout.split()[-1]):>8.2f} s (import included)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--load", action="store_true", help="keep the other core busy meanwhile")
    parser.add_argument("--rounds", type=int, default=5, help="interleaved rounds in part 1")
    parser.add_argument("--skip-scaling", action="store_true", help="part 1 (and 3) only")
    args = parser.parse_args()
    if compiled_kernels("auto") is None:
        print("numba is not importable: only the numpy kernel can be measured", file=sys.stderr)
        raise SystemExit(1)
    for case in cases(2):  # compile or load the kernels before any timing
        rollout(case.control, config=case.config, kernel="numba")
    load = None
    if args.load:  # one spinning process: the other core is taken while we measure
        load = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        print(f"machine: fixed pure-Python workload {calibration() * 1e3:.1f} ms (best of 5)")
        print(f"other core: {'loaded by a spinning process' if load else 'as found'}\n")
        ratios(max(1, args.rounds))
        if not args.skip_scaling:
            scaling()
        compile_time()
        print(f"\nmachine after: fixed workload {calibration() * 1e3:.1f} ms")
    finally:
        if load is not None:
            load.kill()
            load.wait()


if __name__ == "__main__":
    main()

"""Environment steps per second: SnakeVectorEnv at num_envs 1..1024 against single SnakeGymEnvs.

    python -m bench.gym [--sizes 1 4 16 64 256 1024] [--seconds 0.5] [--seed 0]

Two worlds: the default empty arena with the forward IR, and a cluttered one (eight obstacles
around the start, a ring of eight noisy range sensors). Every sub-environment takes seeded
random actions (so robots collide and reset, as early in training); an episode lasts at most
100 steps. The single-env figure is a Python loop over ``SnakeGymEnv.step`` (its rate does not
depend on how many there are). Each figure is env-steps per wall second over at least
``--seconds`` of stepping, best of three; the ratio is vector over single.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import numpy as np

from sim.gym_env import SnakeGymEnv
from sim.obstacles import Circle, rectangle
from sim.sensors import SensorSuite, range_ring
from sim.simulator import Simulator
from sim.vector_env import SnakeVectorEnv
from sim.world import World

GOAL = (-2.0, -2.0)
MAX_STEPS = 100


def empty() -> Simulator:
    return Simulator()


def cluttered() -> Simulator:
    posts = tuple(Circle(2.0 * np.cos(a), 2.0 * np.sin(a), 0.25) for a in np.linspace(0, 6, 6))
    bars = (rectangle(0.0, 1.2, 2.0, 0.1), rectangle(-1.2, -0.8, 0.1, 1.5))
    sensors = SensorSuite(range_ring(8, noise_std=0.01))
    return Simulator(World(obstacles=posts + bars), sensors=sensors)


def rate(run: Callable[[], int], seconds: float) -> float:
    """Best of three: env-steps per wall second of ``run`` repeated for ``seconds``."""
    best = 0.0
    for _ in range(3):
        steps, start = 0, time.perf_counter()
        while (elapsed := time.perf_counter() - start) < seconds:
            steps += run()
        best = max(best, steps / elapsed)
    return best


def vector_rate(world: Callable[[], Simulator], n: int, seconds: float, seed: int) -> float:
    env = SnakeVectorEnv(n, goal=GOAL, max_steps=MAX_STEPS, simulator=world())
    env.reset(seed=seed)
    env.action_space.seed(seed)
    actions = [env.action_space.sample() for _ in range(16)]
    turn = iter(range(1 << 62))

    def run() -> int:
        env.step(actions[next(turn) % len(actions)])
        return n

    return rate(run, seconds)


def single_rate(world: Callable[[], Simulator], seconds: float, seed: int) -> float:
    env = SnakeGymEnv(goal=GOAL, max_steps=MAX_STEPS, simulator=world())
    env.reset(seed=seed)
    env.action_space.seed(seed)
    actions = [env.action_space.sample() for _ in range(16)]
    turn = iter(range(1 << 62))

    def run() -> int:
        _, _, terminated, truncated, _ = env.step(actions[next(turn) % len(actions)])
        if terminated or truncated:
            env.reset()
        return 1

    return rate(run, seconds)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1, 4, 16, 64, 256, 1024])
    parser.add_argument("--seconds", type=float, default=0.5)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    for name, world in (("empty arena", empty), ("cluttered", cluttered)):
        single = single_rate(world, args.seconds, args.seed)
        print(f"{name}: single SnakeGymEnv {single:,.0f} env-steps/s")
        print(f"  {'num_envs':>8}  {'env-steps/s':>12}  {'vs single':>9}")
        for n in args.sizes:
            steps = vector_rate(world, n, args.seconds, args.seed)
            print(f"  {n:>8}  {steps:>12,.0f}  {steps / single:>8.1f}x")


if __name__ == "__main__":
    main()

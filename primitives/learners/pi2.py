"""PI² exactly as the paper (§3.2-§3.4): K = 40, λ = 30, the cost-dependent noise schedule."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from primitives.learners.base import (
    DEFAULT_STOP,
    LearningResult,
    Progress,
    Recorder,
    SettingsFromFields,
    StopRule,
    probability_weights,
)
from primitives.task import Task
from sim.robot import Array


@dataclass(frozen=True)
class PI2(SettingsFromFields):
    """The paper's PI²: zero start, noisy rollouts, probability-weighted noise as the update."""

    rollouts: int = 40
    lam: float = 30.0
    noise_length: float = 10.0  # L in exp(−1/r)/L, metres
    phase_noise: float = 0.02  # std of the phase noise N(0, 0.02) for U3
    name: str = "pi2"

    def noise_std(self, cost: float) -> float:
        """§3.2: exp(−1/r)/L for r > 3 m, 0.05 for 0.5 < r <= 3 m, 0.025 below."""
        if cost > 3.0:
            return math.exp(-1.0 / cost) / self.noise_length
        if cost > 0.5:
            return 0.05
        return 0.025

    def learn(
        self,
        task: Task,
        seed: int,
        stop: StopRule = DEFAULT_STOP,
        initial: Array | None = None,
        progress: Progress | None = None,
    ) -> LearningResult:
        rng = np.random.default_rng(seed)
        space = task.space
        rec = Recorder(progress)
        u, cost = rec.start(task, initial)
        update = 0
        while (
            cost >= stop.threshold
            and update < stop.max_updates
            and rec.rollouts < stop.max_rollouts
        ):
            update += 1
            eps = self.noise_std(cost) * rng.standard_normal((self.rollouts, space.size))
            if space.size > 4:  # U3 with its phases learned too
                eps[:, 4:] = self.phase_noise * rng.standard_normal((self.rollouts, 3))
            noisy = space.clamp(u + eps)
            costs = task.costs(noisy)
            rec.seen(noisy, costs)
            u = space.clamp(u + probability_weights(costs, self.lam) @ eps)  # eq. 11
            cost = float(task.costs(u[None, :])[0])  # the noise-free evaluation
            rec.seen(u[None, :], np.array([cost]))
            rec.record(update, cost, costs, u)
        return rec.result(self.name, self.settings(), seed, u, cost, stop)

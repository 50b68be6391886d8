"""PI^BB with covariance matrix adaptation (PI²-CMA, Stulp & Sigaud 2012), with restarts.

Parameters are sampled from N(m, C); the probability-weighted samples give the new mean and,
by their spread around the old mean, the new covariance. Exploration therefore shrinks and
orients itself as the cost landscape demands instead of following a fixed schedule. Any rollout
below the threshold is a solution already (the simulator is deterministic), so it is returned.

Restarts: a run whose own best has not improved by 1 % for ``patience`` updates has collapsed
on a poor basin, typically a corner of the clamps or a curved valley the weighted mean keeps
stepping off (bench/learning.py, Exp3 seeds 4 and 8). It starts again from the initial
parameters with the initial covariance; restarting from the best point instead (the earlier
rule) falls straight back into the same basin. The best parameters over all runs are returned.
"""

from __future__ import annotations

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
class PI2CMA(SettingsFromFields):
    rollouts: int = 10
    lam: float = 10.0
    sigma0: float = 0.25  # initial exploration of speeds and joints
    phase_sigma0: float = 0.5  # initial exploration of gait phases
    covariance_rate: float = 0.5  # how much of the new covariance replaces the old per update
    min_sigma: float = 1e-4
    patience: int = 6  # updates without a 1 % better run best before a fresh restart
    name: str = "pi2-cma"

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
        sig = np.full(space.size, self.sigma0)
        if space.kind == "U3":
            sig[4:] = self.phase_sigma0
        cov0 = np.diag(sig**2)
        cov = cov0
        rec = Recorder(progress)
        start, start_cost = rec.start(task, initial)
        mean, run_best = start, start_cost
        update, stalled = 0, 0
        while (
            rec.best_cost >= stop.threshold
            and update < stop.max_updates
            and rec.rollouts < stop.max_rollouts
        ):
            update += 1
            chol = np.linalg.cholesky(cov + self.min_sigma**2 * np.eye(space.size))
            samples = space.clamp(mean + rng.standard_normal((self.rollouts, space.size)) @ chol.T)
            costs = task.costs(samples)
            rec.seen(samples, costs)
            p = probability_weights(costs, self.lam)
            spread = samples - mean
            cov = (1 - self.covariance_rate) * cov + self.covariance_rate * (spread.T * p) @ spread
            mean = space.clamp(p @ samples)
            cost = float(task.costs(mean[None, :])[0])
            rec.seen(mean[None, :], np.array([cost]))
            rec.record(update, cost, costs, mean)
            best_now = min(cost, float(costs.min()))
            stalled = 0 if best_now < 0.99 * run_best else stalled + 1
            run_best = min(run_best, best_now)
            if stalled >= self.patience:
                mean, cov, run_best, stalled = start, cov0, start_cost, 0
        assert rec.best_params is not None
        return rec.result(self.name, self.settings(), seed, rec.best_params, rec.best_cost, stop)

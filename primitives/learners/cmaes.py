"""CMA-ES from the ``cma`` package behind the learner interface, on the same batched rollouts."""

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
)
from primitives.task import Task
from sim.robot import Array


@dataclass(frozen=True)
class CMAES(SettingsFromFields):
    popsize: int = 8
    sigma0: float = 0.15
    patience: int = 30  # generations without a 1 % better run best before a fresh restart
    name: str = "cmaes"

    def learn(
        self,
        task: Task,
        seed: int,
        stop: StopRule = DEFAULT_STOP,
        initial: Array | None = None,
        progress: Progress | None = None,
    ) -> LearningResult:
        import cma  # here, not at the top: it takes ~1.7 s to import, and pool workers that
        # learn with PI² would pay it for nothing

        space = task.space
        x0 = space.clamp(np.zeros(space.size) if initial is None else np.asarray(initial, float))
        lo, hi = space.bounds()
        options = {
            "popsize": self.popsize,
            "seed": seed + 1,  # cma treats 0 as "seed from the clock"
            "bounds": [list(lo), list(hi)],
            "verbose": -9,
            "verb_log": 0,  # no output files
            "verb_disp": 0,
            "tolfun": 0.0,
            "tolx": 1e-12,
        }
        es = cma.CMAEvolutionStrategy(list(x0), self.sigma0, options)
        restarts = 0
        rec = Recorder(progress)
        _, start_cost = rec.start(task, x0)
        update, stalled, run_best = 0, 0, start_cost
        while (
            rec.best_cost >= stop.threshold
            and update < stop.max_updates
            and rec.rollouts < stop.max_rollouts
        ):
            update += 1
            xs = np.array(es.ask())
            costs = task.costs(space.clamp(xs))
            es.tell(list(xs), list(costs))
            rec.seen(space.clamp(xs), costs)
            assert rec.best_params is not None
            rec.record(update, rec.best_cost, costs, rec.best_params)
            stalled = 0 if costs.min() < 0.99 * run_best else stalled + 1
            run_best = min(run_best, float(costs.min()))
            if es.stop() or stalled >= self.patience:
                # Restart from the start with a fresh seed: restarting around the best point
                # falls back into the basin the run collapsed on (bench/learning.py, Exp3).
                restarts += 1
                options["seed"] = seed + 1 + 7919 * restarts
                es = cma.CMAEvolutionStrategy(list(x0), self.sigma0, options)
                stalled, run_best = 0, start_cost
        assert rec.best_params is not None
        return rec.result(self.name, self.settings(), seed, rec.best_params, rec.best_cost, stop)

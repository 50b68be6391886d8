"""CMA-ES from the ``cma`` package behind the learner interface, on the same batched rollouts."""

from __future__ import annotations

from dataclasses import dataclass

import cma
import numpy as np

from primitives.learners.base import (
    DEFAULT_STOP,
    LearningResult,
    Progress,
    Recorder,
    SettingsFromFields,
    StopRule,
)
from primitives.task import LearningTask
from sim.robot import Array


@dataclass(frozen=True)
class CMAES(SettingsFromFields):
    popsize: int = 8
    sigma0: float = 0.15
    patience: int = 30  # generations without a 1 % better best before a restart
    name: str = "cmaes"

    def _stalled(self, rec: Recorder) -> bool:
        h = rec.history
        return len(h) > self.patience and h[-1].cost >= 0.99 * h[-1 - self.patience].cost

    def learn(
        self,
        task: LearningTask,
        seed: int,
        stop: StopRule = DEFAULT_STOP,
        initial: Array | None = None,
        progress: Progress | None = None,
    ) -> LearningResult:
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
        rec.start(task, x0)
        update = 0
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
            if es.stop() or self._stalled(rec):
                # Restart around the best point with a fresh seed (a simple restart strategy).
                restarts += 1
                options["seed"] = seed + 1 + 7919 * restarts
                es = cma.CMAEvolutionStrategy(list(rec.best_params), self.sigma0, options)
        assert rec.best_params is not None
        return rec.result(self.name, self.settings(), seed, rec.best_params, rec.best_cost, stop)

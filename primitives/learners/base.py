"""What every learner shares: the stop rule, the per-update record and the result."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any, Protocol

import numpy as np

from primitives.task import Task
from sim.robot import Array


@dataclass(frozen=True)
class StopRule:
    """Stop once the noise-free cost is below ``threshold`` metres, or a budget runs out."""

    threshold: float = 0.05
    max_updates: int = 100
    max_rollouts: int = 100_000

    def __post_init__(self) -> None:
        if not (math.isfinite(self.threshold) and self.threshold > 0):
            raise ValueError("threshold: must be positive and finite")
        if self.max_updates < 1 or self.max_rollouts < 1:
            raise ValueError("max_updates, max_rollouts: must be at least 1")


DEFAULT_STOP = StopRule()


@dataclass(frozen=True)
class UpdateRecord:
    """One update: its noise-free cost, the noisy rollouts' costs, rollouts used so far."""

    update: int
    cost: float
    noisy_costs: list[float]
    rollouts: int
    params: list[float]


@dataclass
class LearningResult:
    learner: str
    settings: dict[str, Any]
    seed: int
    params: list[float]
    cost: float
    converged: bool
    updates: int
    rollouts: int
    wall_time: float
    history: list[UpdateRecord] = field(default_factory=list)

    @property
    def curve(self) -> list[float]:
        """Noise-free cost after each update, starting with the initial parameters."""
        return [h.cost for h in self.history]

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


Progress = Callable[[UpdateRecord], None]


class SettingsFromFields:
    """``settings()`` for dataclass learners: every field but the name (stored with results)."""

    def settings(self) -> dict[str, Any]:
        return {k: v for k, v in asdict(self).items() if k != "name"}  # type: ignore[call-overload]


class CancelledError(Exception):
    """Raised inside a learner when its progress callback asks it to stop."""


class Learner(Protocol):
    """A learner improves parameters for a task with batched rollouts, reproducibly per seed."""

    @property
    def name(self) -> str: ...

    def settings(self) -> dict[str, Any]: ...

    def learn(
        self,
        task: Task,
        seed: int,
        stop: StopRule = ...,
        initial: Array | None = None,
        progress: Progress | None = None,
    ) -> LearningResult: ...


def probability_weights(costs: Array, lam: float) -> Array:
    """Eqs. 9-10: S = exp(−λ (I − min)/(max − min)), normalised to probabilities."""
    lo, hi = float(costs.min()), float(costs.max())
    if hi - lo < 1e-15:
        return np.full(costs.shape, 1.0 / costs.size)
    s = np.exp(-lam * (costs - lo) / (hi - lo))
    out: Array = s / s.sum()
    return out


class Recorder:
    """Keeps the history, the rollout count, the best parameters seen and the wall clock."""

    def __init__(self, progress: Progress | None) -> None:
        self.history: list[UpdateRecord] = []
        self.rollouts = 0
        self.best_cost = math.inf
        self.best_params: Array | None = None
        self.progress = progress
        self.started = time.perf_counter()

    def start(self, task: Task, initial: Array | None) -> tuple[Array, float]:
        """The clamped start (zeros unless given), evaluated noise-free and recorded as update 0."""
        space = task.space
        u = space.clamp(np.zeros(space.size) if initial is None else np.asarray(initial, float))
        cost = float(task.costs(u[None, :])[0])
        self.seen(u[None, :], np.array([cost]))
        self.record(0, cost, np.array([]), u)
        return u, cost

    def seen(self, params: Array, costs: Array) -> None:
        """Count rollouts and remember the best parameter vector among them."""
        self.rollouts += len(costs)
        i = int(np.argmin(costs))
        if costs[i] < self.best_cost:
            self.best_cost, self.best_params = float(costs[i]), np.array(params[i])

    def record(self, update: int, cost: float, noisy: Array, params: Array) -> None:
        rec = UpdateRecord(
            update,
            float(cost),
            [float(c) for c in noisy],
            self.rollouts,
            [float(p) for p in params],
        )
        self.history.append(rec)
        if self.progress is not None:
            self.progress(rec)

    def result(
        self,
        name: str,
        settings: dict[str, Any],
        seed: int,
        params: Array,
        cost: float,
        stop: StopRule,
    ) -> LearningResult:
        return LearningResult(
            learner=name,
            settings=settings,
            seed=seed,
            params=[float(p) for p in params],
            cost=float(cost),
            converged=bool(cost < stop.threshold),
            updates=len(self.history) - 1,
            rollouts=self.rollouts,
            wall_time=time.perf_counter() - self.started,
            history=self.history,
        )

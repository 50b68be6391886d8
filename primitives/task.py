"""A learning task: reach a goal from the start pose in one rollout; cost = final distance."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike

from primitives.params import ParameterSpace
from sim.robot import Array
from sim.rollout import PAPER_ROLLOUT, RolloutConfig, rollout


class Task(Protocol):
    """What a learner needs of a task: the parameter space and batched costs ``[K]``."""

    @property
    def space(self) -> ParameterSpace: ...

    def costs(self, params: ArrayLike) -> Array: ...


@dataclass(frozen=True)
class LearningTask:
    """Reach ``goal`` (metres, world frame) from ``start`` within one rollout of ``config``."""

    goal: tuple[float, float]
    space: ParameterSpace
    start: tuple[float, float, float] = (0.0, 0.0, 0.0)
    config: RolloutConfig = field(default=PAPER_ROLLOUT)

    def __post_init__(self) -> None:
        if len(self.goal) != 2 or not all(math.isfinite(v) for v in self.goal):
            raise ValueError("goal: need two finite coordinates")

    def end_points(self, params: ArrayLike) -> Array:
        """End positions ``[K, 2]`` of a batch of parameter vectors (one batched rollout)."""
        end = rollout(self.space.control(params), self.start, self.config).end
        return end[:, :2]

    def costs(self, params: ArrayLike) -> Array:
        """Eq. 6: Euclidean distance of each end point to the goal, ``[K]``."""
        out: Array = np.linalg.norm(self.end_points(params) - np.asarray(self.goal), axis=-1)
        return out

    @property
    def start_distance(self) -> float:
        return math.hypot(self.goal[0] - self.start[0], self.goal[1] - self.start[1])

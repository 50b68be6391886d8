"""A better generaliser than bilinear: angle-aware blending of primitives, refined by rollouts.

For a fixed shape the body twist is linear in the screw speeds, so if primitive i lands at e_i
and primitive j at e_j, then a·θ_i + b·θ_j lands near a·e_i + b·e_j (exactly, were it not for
the body turning on the way). For a goal g we blend the two primitives whose *actual* end
points bracket g's direction, with (a, b) solving a·e_i + b·e_j = g. This is what bilinear
interpolation approximates on a grid, but it respects direction, uses where primitives really
land, and extrapolates beyond the 2 m square.

The remaining error comes from the turning body. Two refinements remove it, both by running
the model forwards only (never inverting it): a few damped Gauss-Newton steps whose Jacobian
comes from finite-difference rollouts in one batched call, or the issue's short PI² run seeded
by the prediction.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from primitives.interpolation import Interpolated
from primitives.learners import PI2, StopRule
from primitives.library import Library, Primitive
from primitives.params import ParameterSpace
from primitives.task import LearningTask
from sim.robot import Array

FD_STEP = 1e-4  # rad/s: finite-difference step of the Jacobian


def bracketing_pair(
    entries: Sequence[Primitive], goal: tuple[float, float]
) -> tuple[Primitive, Primitive]:
    """The primitives whose end points are nearest in direction on either side of ``goal``."""
    ends = np.array([e.end for e in entries])
    offset = (np.arctan2(ends[:, 1], ends[:, 0]) - math.atan2(goal[1], goal[0]) + np.pi) % (
        2 * np.pi
    ) - np.pi
    right = int(np.argmin(np.where(offset <= 0, -offset, np.inf)))
    left = int(np.argmin(np.where(offset > 0, offset, np.inf)))
    if not np.isfinite(offset[right]) or offset[right] > 0 or offset[left] <= 0:
        raise ValueError("entries: primitives must surround the start in direction")
    return entries[right], entries[left]


def blend(entries: Sequence[Primitive], goal: tuple[float, float]) -> tuple[Array, tuple[str, str]]:
    """Screw speeds a·θ_i + b·θ_j with a·e_i + b·e_j = goal, and the two primitives' names."""
    first, second = bracketing_pair(entries, goal)
    basis = np.array([first.end, second.end]).T
    weights = np.linalg.lstsq(basis, np.asarray(goal, dtype=float), rcond=None)[0]
    theta = weights[0] * np.array(first.theta) + weights[1] * np.array(second.theta)
    return np.clip(theta, -1.0, 1.0), (first.name, second.name)


def newton_refine(
    task: LearningTask, theta: Array, iterations: int, threshold: float
) -> tuple[Array, float, int]:
    """Damped Gauss-Newton on the end point; each iteration is one batched call of 5 rollouts."""
    probes = np.vstack([np.zeros(4), FD_STEP * np.eye(4)])
    rollouts, step = 0, 1.0
    ends = task.end_points(np.clip(theta + probes, -1, 1))
    rollouts += 5
    cost = float(np.linalg.norm(ends[0] - task.goal))
    for _ in range(iterations):
        if cost < threshold:
            break
        jac = ((ends[1:] - ends[0]) / FD_STEP).T  # [2, 4]
        delta = np.linalg.pinv(jac) @ (np.asarray(task.goal) - ends[0])  # minimum-norm step
        candidate = np.clip(theta + step * delta, -1.0, 1.0)
        new_ends = task.end_points(np.clip(candidate + probes, -1, 1))
        rollouts += 5
        new_cost = float(np.linalg.norm(new_ends[0] - task.goal))
        if new_cost < cost:
            theta, ends, cost, step = candidate, new_ends, new_cost, min(1.0, 2 * step)
        else:
            step /= 2  # overshoot where the body turns a lot: shorten the step
    return theta, cost, rollouts


class Generaliser:
    """Parameters for new goals of a fixed shape from the library's primitives of that shape."""

    def __init__(self, library: Library) -> None:
        self.library = library

    def _entries(self, shape: str) -> list[Primitive]:
        entries = [e for e in self.library.of_shape(shape) if not e.periodic]
        if len(entries) < 3:
            raise KeyError(f"the library has fewer than 3 fixed primitives of shape {shape!r}")
        return entries

    def _task(self, goal: tuple[float, float], entries: Sequence[Primitive]) -> LearningTask:
        return LearningTask(goal, ParameterSpace("U1", entries[0].joints or (0.0, 0.0, 0.0)))

    def predict(self, goal: tuple[float, float], shape: str) -> Interpolated:
        """The blend alone: no rollouts."""
        entries = self._entries(shape)
        theta, names = blend(entries, goal)
        params = np.concatenate([theta, entries[0].joints or (0.0, 0.0, 0.0)])
        return Interpolated(goal, params, names, "blend")

    def refine(
        self,
        goal: tuple[float, float],
        shape: str,
        method: str = "newton",
        threshold: float = 0.01,
        budget: int = 6,
        seed: int = 0,
    ) -> Interpolated:
        """The blend refined by ``budget`` Gauss-Newton iterations or PI² updates."""
        entries = self._entries(shape)
        first = self.predict(goal, shape)
        task = self._task(goal, entries)
        if method == "newton":
            theta, cost, rollouts = newton_refine(task, first.theta, budget, threshold)
        elif method == "pi2":
            result = PI2().learn(task, seed, StopRule(threshold, budget), initial=first.theta)
            theta, cost, rollouts = np.asarray(result.params), result.cost, result.rollouts
        else:
            raise ValueError(f"method: newton or pi2, got {method!r}")
        params = np.concatenate([theta, first.joints])
        extra: dict[str, object] = {"error": cost, "rollouts": rollouts}
        return Interpolated(goal, params, first.sources, f"blend+{method}", "", extra)


def refine_aim(
    entries: Sequence[Primitive],
    goal: tuple[float, float],
    iterations: int = 6,
    threshold: float = 0.01,
) -> tuple[Interpolated, float, int]:
    """The paper's bilinear interpolation (eqs. 16-18) of ``entries`` aimed where it lands on
    ``goal``: a few Newton steps on the aim point, whose Jacobian comes from finite-difference
    rollouts. The behaviour stays an interpolation of the same three primitives (parameters
    f(G') for an aim G'); only G' is learned, as a library-building step, never by a running
    mission. Returns it, its end-point error (m) and the rollouts used."""
    from primitives.interpolation import interpolate_entries
    from sim.rollout import rollout

    def end_of(aim: Array) -> Array:
        made = interpolate_entries(entries, (float(aim[0]), float(aim[1])))
        return np.asarray(rollout(made.control()).end[0][:2], dtype=float)

    target = np.asarray(goal, dtype=float)
    aim, step = target.copy(), 1e-3
    end = end_of(aim)
    rollouts = 1
    for _ in range(iterations):
        if float(np.linalg.norm(end - target)) < threshold:
            break
        jac = np.column_stack([(end_of(aim + step * e) - end) / step for e in np.eye(2)])
        aim = aim + np.linalg.lstsq(jac, target - end, rcond=None)[0]
        end = end_of(aim)
        rollouts += 3
    made = interpolate_entries(entries, (float(aim[0]), float(aim[1])))
    error = float(np.linalg.norm(end - target))
    extra: dict[str, object] = {"aim": [float(aim[0]), float(aim[1])], "error": error}
    out = Interpolated(goal, made.params, made.sources, "bilinear+aim", made.quadrant, extra)
    return out, error, rollouts

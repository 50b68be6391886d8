"""The mission's behaviour tree (DESIGN §6) and JSON snapshots of it."""

from __future__ import annotations

from typing import Any

import py_trees
from py_trees.composites import Selector, Sequence

from app.executor.behaviours import (
    FollowPlan,
    GoalReached,
    HavePlan,
    ObstacleGuard,
    ProgressGuard,
    Replan,
    ShapeGuard,
)
from app.executor.chain import ChainStepBehaviour
from app.missions.spec import MissionSpec


def goal_subtree(name: str, ns: str, index: int | None) -> py_trees.behaviour.Behaviour:
    """reached? || (plan ok && guards ok && follow) || replan — re-evaluated every tick."""
    execute = Sequence(
        "execute",
        memory=False,
        children=[
            HavePlan("have plan", ns),
            ObstacleGuard("guard: obstacle", ns),
            ShapeGuard("guard: body shape", ns),
            ProgressGuard("guard: progress", ns),
            FollowPlan("follow plan", ns),
        ],
    )
    return Selector(
        name,
        memory=False,
        children=[GoalReached("reached?", ns, index), execute, Replan("replan", ns)],
    )


def build_tree(spec: MissionSpec, ns: str) -> py_trees.behaviour.Behaviour:
    """One tree per mission: a manual chain, a tour of goals in any order, or goals in sequence."""
    if spec.chain:
        steps = [
            Sequence(
                f"step {i}",
                memory=False,
                children=[
                    ShapeGuardQuiet(f"guard: body shape {i}", ns),
                    ChainStepBehaviour(f"chain step {i}", ns, i),
                ],
            )
            for i in range(len(spec.chain))
        ]
        children: list[py_trees.behaviour.Behaviour] = [
            Sequence("chain", memory=True, children=steps)
        ]
        if spec.goals:
            children.append(GoalReached("goals reached?", ns, None))
        return Sequence(spec.name, memory=True, children=children)
    if spec.order == "any" and spec.planner.domain == "navigation":
        return Sequence(
            spec.name, memory=True, children=[goal_subtree("tour of all goals", ns, None)]
        )
    goals = [goal_subtree(f"goal {i}", ns, i) for i in range(len(spec.goals))]
    return Sequence(spec.name, memory=True, children=goals)


class ShapeGuardQuiet(ShapeGuard):
    """In a manual chain a deformation only re-grounds the step: the guard never fails it."""

    def update(self) -> py_trees.common.Status:
        status = super().update()
        ctx = self.ctx
        ctx.trigger = None
        if status == py_trees.common.Status.FAILURE and ctx.failure is None:
            return py_trees.common.Status.SUCCESS
        return status


def snapshot(root: py_trees.behaviour.Behaviour) -> dict[str, Any]:
    """Names, statuses and children of the tree, as JSON-ready data."""
    return {
        "name": root.name,
        "type": type(root).__name__,
        "status": root.status.value,
        "children": [snapshot(c) for c in root.children],
    }

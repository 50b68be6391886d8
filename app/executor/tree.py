"""The mission's behaviour tree (DESIGN §6) and JSON snapshots of it."""

from __future__ import annotations

from typing import Any

import py_trees
from py_trees.composites import Selector, Sequence

from app.executor.behaviours import (
    Execute,
    GoalsReached,
    PlanGuard,
    Replan,
    Sense,
    ShapeGuard,
)
from app.executor.chain import ChainShapeGuard, ChainStepBehaviour
from app.missions.spec import MissionSpec


def goals_tree(name: str, ns: str) -> py_trees.behaviour.Behaviour:
    """reached? || (sense && shape ok && plan ok && execute) || replan — every tick."""
    execute = Sequence(
        "execute",
        memory=False,
        children=[
            Sense("sense", ns),
            ShapeGuard("guard: body shape", ns),
            PlanGuard("guard: plan holds", ns),
            Execute("execute plan", ns),
        ],
    )
    return Selector(
        name,
        memory=False,
        children=[GoalsReached("goals reached?", ns), execute, Replan("replan", ns)],
    )


def build_tree(spec: MissionSpec, ns: str) -> py_trees.behaviour.Behaviour:
    """One tree per mission: a manual chain of primitives, or the goals through a planner."""
    if spec.chain:
        steps = [
            Sequence(
                f"step {i}",
                memory=False,
                children=[
                    ChainShapeGuard(f"guard: body shape {i}", ns),
                    ChainStepBehaviour(f"chain step {i}", ns, i),
                ],
            )
            for i in range(len(spec.chain))
        ]
        children: list[py_trees.behaviour.Behaviour] = [
            Sequence("chain", memory=True, children=steps)
        ]
        return Sequence(spec.name, memory=True, children=children)
    return Sequence(spec.name, memory=True, children=[goals_tree("goals", ns)])


def snapshot(root: py_trees.behaviour.Behaviour) -> dict[str, Any]:
    """Names, statuses, feedback and children of the tree, as JSON-ready data."""
    return {
        "name": root.name,
        "type": type(root).__name__,
        "status": root.status.value,
        "feedback": root.feedback_message,
        "children": [snapshot(c) for c in root.children],
    }

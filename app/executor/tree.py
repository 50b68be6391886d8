"""The mission's behaviour tree, and JSON snapshots of it.

A goals mission, every tick (``memory=False`` composites re-check their guards each tick)::

    <mission>                          Sequence
      goals                            Selector: done, or navigate
        goals reached?
        navigate                       Sequence
          sense                        range readings, the body's cells, contacts
          guard: progress              ends the mission when it stops getting closer
          guard: body shape            a deformation replans; an uncovered shape ends it
          navigate with recovery       RecoveryNode (Nav2's)
            follow plan                Sequence
              guard: plan holds        a blocked step leaves a trigger
              plan                     plans when a trigger is pending or there is no plan
              execute plan             the strategy's command for the next tick
            recover                    Selector
              back off                 after a contact, or from a blocked start
              sense and retry          RoundRobin (Nav2's)
                spin to sense
                reshape
                clear stale evidence
"""

from __future__ import annotations

from typing import Any

import py_trees

from app.executor.behaviours import (
    Execute,
    GoalsReached,
    Plan,
    PlanGuard,
    ProgressGuard,
    Sense,
    ShapeGuard,
)
from app.executor.chain import ChainShapeGuard, ChainStepBehaviour
from app.executor.light import Selector, Sequence
from app.executor.recoveries import RecoveryNode, recovery_tree, robot_position
from app.missions.spec import MissionSpec
from domain.navigation import RecoverySettings


def goals_tree(name: str, ns: str, recovery: RecoverySettings) -> py_trees.behaviour.Behaviour:
    """The goals through a planner, with the recoveries (see the module's docstring)."""
    follow = Sequence(
        "follow plan",
        memory=False,
        children=[
            PlanGuard("guard: plan holds", ns),
            Plan("plan", ns),
            Execute("execute plan", ns),
        ],
    )
    navigate = Sequence(
        "navigate",
        memory=False,
        children=[
            Sense("sense", ns),
            ProgressGuard("guard: progress", ns),
            ShapeGuard("guard: body shape", ns),
            RecoveryNode(
                "navigate with recovery",
                follow,
                recovery_tree(ns),
                recovery.retries,
                recovery.settle_distance,
                robot_position(ns),
            ),
        ],
    )
    return Selector(name, memory=False, children=[GoalsReached("goals reached?", ns), navigate])


def build_tree(
    spec: MissionSpec, ns: str, recovery: RecoverySettings | None = None
) -> py_trees.behaviour.Behaviour:
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
    tree = goals_tree("goals", ns, recovery or RecoverySettings())
    return Sequence(spec.name, memory=True, children=[tree])


def snapshot(root: py_trees.behaviour.Behaviour) -> dict[str, Any]:
    """Names, statuses, feedback and children of the tree, as JSON-ready data."""
    return {
        "name": root.name,
        "type": type(root).__name__,
        "status": root.status.value,
        "feedback": root.feedback_message,
        "children": [snapshot(c) for c in root.children],
    }

"""Everything one running mission shares between its behaviours, and its result."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from app.missions.spec import MissionSpec
from domain.knowledge import WorldKnowledge
from domain.navigation import NavigationPlan
from domain.reactive import ReactiveStep
from domain.replanner import Replanner
from domain.triggers import ReplanRecord, Trigger
from primitives.library import Library
from primitives.steering import Steering
from sim.controls import Control
from sim.sensors import SensorReadings
from sim.simulator import Simulator


@dataclass
class GoalState:
    x: float
    y: float
    tolerance: float
    reached: bool = False
    error: float | None = None
    reached_at: float | None = None

    def distance(self, x: float, y: float) -> float:
        return math.hypot(self.x - x, self.y - y)

    def to_dict(self) -> dict[str, Any]:
        return {
            "x": self.x,
            "y": self.y,
            "tolerance": self.tolerance,
            "reached": self.reached,
            "error": self.error,
            "reached_at": self.reached_at,
        }


@dataclass
class MissionContext:
    """The blackboard's one entry per mission: world, knowledge, plan and the log."""

    spec: MissionSpec
    library: Library
    steering: Steering
    sim: Simulator
    knowledge: WorldKnowledge
    goals: list[GoalState]
    replanner: Replanner | None = None
    plan: NavigationPlan | None = None
    plan_version: int = 0
    action_index: int = 0
    reactive_steps: list[ReactiveStep] = field(default_factory=list)
    reactive_cleared: float = 0.0  # metres travelled with the goal direction clear (PO2/PO3)
    trigger: Trigger | None = None
    replans: list[ReplanRecord] = field(default_factory=list)
    shape: str = "straight"  # commanded body shape (a library shape)
    readings: SensorReadings | None = None
    command: Control | None = None
    current_action: str = ""
    grounding: dict[str, Any] = field(default_factory=dict)
    failure: str | None = None
    events: list[dict[str, Any]] = field(default_factory=list)
    pddl: list[dict[str, Any]] = field(default_factory=list)
    progress_best: float = math.inf
    progress_since: float = 0.0
    goal_map: list[int] = field(default_factory=list)  # planner goal j -> mission goal index
    collisions_seen: int = 0
    gait_t0: float = 0.0  # the periodic gait's phase origin (continuous joints across intervals)
    interval: float = 1.0  # model seconds per control interval
    chain_started: float = 0.0

    @property
    def t(self) -> float:
        return self.sim.t

    @property
    def pose(self) -> tuple[float, float, float]:
        x, y, psi = (float(v) for v in self.sim.pose)
        return (x, y, psi)

    def event(self, kind: str, **detail: Any) -> None:
        self.events.append({"t": round(self.t, 3), "kind": kind, **detail})

    def remaining_goals(self) -> list[int]:
        return [i for i, g in enumerate(self.goals) if not g.reached]

    def mark_reached(self, index: int) -> None:
        goal = self.goals[index]
        if goal.reached:
            return
        x, y, _ = self.pose
        goal.reached, goal.error, goal.reached_at = True, goal.distance(x, y), round(self.t, 3)
        self.event("goal_reached", goal=index, error=round(goal.error, 4))


@dataclass
class MissionResult:
    name: str
    status: str  # succeeded | failed | cancelled
    reason: str
    goals: list[GoalState]
    collisions: int
    replans: list[ReplanRecord]
    model_time: float
    wall_time: float
    trajectory: list[list[float]]
    events: list[dict[str, Any]]
    pddl: list[dict[str, Any]]

    def summary(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "status": self.status,
            "reason": self.reason,
            "goals": [g.to_dict() for g in self.goals],
            "collisions": self.collisions,
            "replans": [r.to_dict() for r in self.replans],
            "model_time": self.model_time,
            "wall_time": self.wall_time,
        }

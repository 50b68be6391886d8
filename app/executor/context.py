"""Everything one running mission shares between its behaviours, and its result.

The context holds what the robot reports (the latest ``Observation`` through the Robot port),
the world model built from it, the planning strategy and the mission's log. Nothing here is
simulator state.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from app.executor.learning import LearningSettings
from app.executor.plan_versions import SEARCHES_KEPT, PlanVersion
from app.executor.robot import ContactReading, Observation, Robot
from app.missions.spec import MissionSpec
from domain.goal_order import LegGoal
from domain.navigation import HeadView, NavigationSettings
from domain.pyperplan_adapter import CancelFlag
from domain.strategy import PlanningStrategy, Situation
from domain.triggers import ReplanRecord, Trigger
from domain.world import WorldModel
from primitives.library import Library
from sim.controls import Control


@dataclass
class GoalState:
    x: float
    y: float
    tolerance: float
    reached: bool = False
    error: float | None = None
    reached_at: float | None = None
    removed: bool = False  # removed by a live update: no longer pursued

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
            "removed": self.removed,
        }


@dataclass
class MissionContext:
    """The blackboard's one entry per mission."""

    spec: MissionSpec
    library: Library
    robot: Robot
    world: WorldModel
    strategy: PlanningStrategy | None
    observation: Observation
    goals: list[GoalState]
    shape: str = "straight"  # the library shape the body is classified as (or learned)
    joints: tuple[float, float, float] = (0.0, 0.0, 0.0)  # commanded joint angles
    deformed: bool = False  # the joint sensors once disagreed with the command for good
    reshaping: bool = False  # a commanded shape change runs: the joints travel on purpose
    trigger: Trigger | None = None
    replans: list[ReplanRecord] = field(default_factory=list)
    plan_version: int = 0
    have_plan: bool = False
    command: Control | None = None
    current_action: str = ""
    grounding: dict[str, Any] = field(default_factory=dict)
    failure: str | None = None
    events: list[dict[str, Any]] = field(default_factory=list)
    pddl: list[PlanVersion] = field(default_factory=list)
    searches_kept: int = SEARCHES_KEPT  # newest plan versions keeping their searches whole
    contacts: int = 0
    settings: NavigationSettings = field(default_factory=NavigationSettings)
    view: HeadView = field(default_factory=HeadView.default)  # the head's rays, as planned
    # What the recoveries read: a contact not yet backed off from, the last planning failure
    # (its kind and, for an unreachable goal, what proves it) and why the plan stopped.
    contact: ContactReading | None = None
    plan_failure: str | None = None
    plan_proof: str | None = None
    failure_reason: str | None = None
    recoveries: int = 0  # recoveries run
    spin_direction: int = 1  # the last spin's direction (the next turns the other way)
    shapes_tried: set[str] = field(default_factory=set)  # reshaped from since the last plan
    cleared_for: set[tuple[int, ...]] = field(default_factory=set)  # goals left when cleared
    interval: float = 0.25  # model seconds per control tick
    chain_started: float = 0.0
    chain_entry_pose: tuple[float, float, float] | None = None
    executed: list[dict[str, Any]] = field(default_factory=list)
    cancel: CancelFlag | None = None  # the mission's cancel flag, passed to the planner
    # A start shape the library has no lattice for (learned before the first plan); how a
    # guard has a shape learned (the runner's ``learn_shape``: None, or why it could not); and
    # how far learning got (done / total primitives, for the state frames).
    learn: tuple[float, float, float] | None = None
    learn_shape: Callable[[tuple[float, float, float]], str | None] | None = None
    learning: dict[str, Any] | None = None
    learning_settings: LearningSettings = field(default_factory=LearningSettings)
    # the last situation and what it was built from: the guards and the execution ask for
    # it in the same tick, and the remaining goals change seldom
    _situation: tuple[Observation, tuple[Any, ...], Situation] | None = field(
        default=None, repr=False, compare=False
    )

    @property
    def t(self) -> float:
        return self.observation.t

    @property
    def pose(self) -> tuple[float, float, float]:
        return self.observation.pose

    @property
    def on_lattice(self) -> bool:
        """Whether the mission plans on the lattice: its body needs a lattice shape within
        the learning tolerance (else it learns one), not a blend of paper shapes."""
        return bool(self.spec.goals) and self.spec.planner.domain == "navigation"

    def sensed_joints(self) -> tuple[float, float, float]:
        j = self.observation.joints
        if all(math.isfinite(v) for v in j):
            return j
        return self.joints  # joint sensors dropped out: the commanded shape is the best guess

    def event(self, kind: str, **detail: Any) -> None:
        self.events.append({"t": round(self.t, 3), "kind": kind, **detail})

    def record_executed(self, duration: float) -> None:
        """Log the command about to run for ``duration``: consecutive ticks of one action and
        grounding method extend one entry (what a user reads as the executed chain)."""
        g = self.grounding
        ids = [str(p) for p in g.get("primitives", [])]
        x, y, _ = self.pose
        last = self.executed[-1] if self.executed else None
        if last is not None and (last["action"], last["method"]) == (
            self.current_action,
            g.get("method"),
        ):
            last["to"] = round(self.t + duration, 3)
            for p in ids:  # a re-grounded action lists every primitive it ran
                if p not in last["primitives"]:
                    last["primitives"].append(p)
                    last["labels"].append(self.library.get(p).name if p in self.library else p)
            return
        if last is not None:
            last["end"] = [round(x, 4), round(y, 4)]
        self.executed.append(
            {
                "from": round(self.t, 3),
                "to": round(self.t + duration, 3),
                "action": self.current_action,
                "method": g.get("method"),
                "primitives": ids,
                "labels": [self.library.get(p).name if p in self.library else p for p in ids],
                "shape": self.shape,
                "towards_deg": g.get("towards_deg"),  # an interpolation's aim, paper labels
                "start": [round(x, 4), round(y, 4)],
                "end": None,
            }
        )

    def close_executed(self) -> None:
        """The last entry's end point is where the robot is now."""
        if self.executed and self.executed[-1]["end"] is None:
            x, y, _ = self.pose
            self.executed[-1]["end"] = [round(x, 4), round(y, 4)]

    def remaining_goals(self) -> list[int]:
        return [i for i, g in enumerate(self.goals) if not (g.reached or g.removed)]

    def mark_reached(self, index: int) -> None:
        goal = self.goals[index]
        if goal.reached:
            return
        x, y, _ = self.pose
        goal.reached, goal.error, goal.reached_at = True, goal.distance(x, y), round(self.t, 3)
        self.event("goal_reached", goal=index, error=round(goal.error, 4))

    def situation(self) -> Situation:
        """What the strategy gets to decide on; the same object while nothing it holds changed
        (the same observation, shape, joints and remaining goals)."""
        left = tuple(self.remaining_goals())
        key = (self.shape, self.deformed, self.joints, left, self.world)
        cached = self._situation
        if cached is not None and cached[0] is self.observation and cached[1] == key:
            return cached[2]
        if cached is not None and cached[1][3] == left:
            goals = cached[2].goals
        else:
            goals = tuple(
                LegGoal(i, self.goals[i].x, self.goals[i].y, self.goals[i].tolerance) for i in left
            )
        situation = Situation(
            t=self.t,
            pose=self.pose,
            joints=self.sensed_joints(),
            shape=self.shape,
            goals=goals,
            ordered=self.spec.order == "given",
            world=self.world,
            ranges=self.observation.ranges,
            deformed=self.deformed,
        )
        self._situation = (self.observation, key, situation)
        return situation


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
    pddl: list[PlanVersion]  # every plan version (its problem written when read)
    executed: list[dict[str, Any]] = field(default_factory=list)

    def chain(self) -> list[str]:
        """The executed behaviours as a user reads them: each entry's primitive labels joined
        with '+' (one primitive, or the sources of an interpolation), in order."""
        return ["+".join(e["labels"]) for e in self.executed if e["labels"]]

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
            "executed": self.executed,
        }

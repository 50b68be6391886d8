"""What a planner is asked and what it answers: ``PlanRequest -> Plan | Failure``.

A ``Plan`` is a sequence of ``PlanAction``s (a library primitive between lattice states, or a
goal visit) with what its searches saw (the PDDL problem it solves). A ``Failure`` says why
there is none, typed: its ``kind`` and, for an unreachable goal, what proves it (the known map
alone, or sensed obstacles too), so the behaviour tree can choose a recovery.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

from domain.goal_order import LegGoal
from domain.navigation.lattice.grid import Key
from domain.navigation.lattice.motions import MotionTable
from domain.navigation.lattice.pddl import lattice_problem
from domain.navigation.lattice.task import LatticeTask
from domain.pddl import Problem
from domain.pyperplan_adapter import CancelFlag
from domain.world import WorldModel

FailureKind = Literal["unreachable", "timeout", "start_blocked", "no_primitives", "cancelled"]
Proof = Literal["known", "sensed"]


def leg_reach(goal: LegGoal) -> float:
    """How close the tracked point must come to a goal for the plan to visit it."""
    return max(0.03, 0.6 * goal.tolerance)


@dataclass(frozen=True)
class PlanRequest:
    """Plan for this body from this pose through these goals on this world model."""

    pose: tuple[float, float, float]
    table: MotionTable
    goals: tuple[LegGoal, ...]
    ordered: bool
    world: WorldModel
    cancel: CancelFlag | None = None


@dataclass(frozen=True)
class PlanAction:
    """One step of a plan: a primitive from one lattice state to the next, or a goal visit."""

    name: str  # "move" or "visit"
    pddl: str
    primitive: str | None  # library id of a move
    target: tuple[float, float, float]  # tracked-point pose at the end (x, y, ψ)
    duration: float
    goal: int | None = None  # mission goal index of a visit
    source: Key | None = None  # lattice state the move starts from
    motion: int | None = None  # index of the move's motion in the shape's motion table
    cost: float = 0.0  # metres (``domain.navigation.lattice.costs``)


@dataclass
class Plan:
    """A plan (``partial``: towards the goal only, the search's best node when its budget ran
    out: the rest is planned again from there)."""

    actions: list[PlanAction]
    order: list[int] = field(default_factory=list)  # mission goal indices in tour order
    expansions: int = 0
    search_ms: float = 0.0
    partial: bool = False
    legs: list[LatticeTask] = field(default_factory=list)  # every leg's task (the PDDL export)
    shape: str = ""

    @property
    def pddl_plan(self) -> list[str]:
        return [a.pddl for a in self.actions]

    @property
    def cost(self) -> float:
        """The plan's cost in metres."""
        return sum(a.cost for a in self.actions)

    def problem(self) -> Problem | None:
        """The PDDL problem this plan solves (the lattice its searches generated), if any."""
        return lattice_problem(self.legs, self.shape) if self.legs else None

    def release(self) -> None:
        """Let go of what the legs' searches kept beyond what ``problem`` reads: the plan was
        superseded."""
        for task in self.legs:
            task.release()


@dataclass(frozen=True)
class Failure:
    """Why there is no plan. ``proof`` (for ``unreachable``): the known map proves it alone,
    or only with sensed obstacles (which sensing again may clear)."""

    kind: FailureKind
    reason: str
    proof: Proof | None = None
    goal: int | None = None
    expansions: int = 0
    search_ms: float = 0.0

    @property
    def status(self) -> str:
        """The status a replan record shows."""
        return self.kind

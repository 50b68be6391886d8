"""One PlanningStrategy protocol: the executor plans, checks and executes through it alone.

A strategy owns its plan and its state; the executor hands it a ``Situation`` (what the robot
knows now: time, tracked pose, sensed joints, body shape, remaining goals, the world model and
the latest range readings) and asks three things: replan after a trigger, whether the current
plan is broken (a precondition violated), and the command for the next control tick. The
navigation strategy (``domain.navigation``) plans on the primitive lattice; the
reactive one (``domain.reactive_strategy``) is the paper's Table 3 domain.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, Protocol

from domain.goal_order import LegGoal
from domain.pyperplan_adapter import CancelFlag
from domain.triggers import ReplanRecord, Trigger
from domain.world import RangeObservation, WorldModel
from sim.controls import Control


@dataclass(frozen=True)
class Situation:
    """What the executor knows now (never simulator truth)."""

    t: float
    pose: tuple[float, float, float]
    joints: tuple[float, float, float]  # sensed (the commanded ones while the sensors drop out)
    shape: str  # the library shape the body is classified as
    goals: tuple[LegGoal, ...]  # remaining goals, mission indices kept
    ordered: bool
    world: WorldModel
    ranges: tuple[tuple[str, RangeObservation], ...] = ()
    deformed: bool = False  # the body was forced into its shape: it cannot take another


@dataclass(frozen=True)
class Command:
    """The control for the next tick and what it executes."""

    control: Control
    action: str  # the plan step, as PDDL text
    grounding: dict[str, Any] = field(default_factory=dict)
    shape: str | None = None  # the library shape the control's joints take (None: unchanged)


@dataclass(frozen=True)
class Replanned:
    """The outcome of a replan: a plan (``ok``) or the reason there is none. The PDDL problem
    is written when first read (``problem_pddl``): a mission that nobody asks for its problems
    does not pay for writing them at every replan."""

    ok: bool
    reason: str
    record: ReplanRecord
    domain_pddl: str
    export: Callable[[], str] = field(repr=False, compare=False)  # writes the problem's text
    plan: list[str] = field(default_factory=list)
    # Why there is no plan (``ok`` False): ``unreachable``, ``timeout``, ``start_blocked``,
    # ``no_primitives``, ``cancelled``, ... and, for an unreachable goal, what proves it
    # (``known``: the known map alone; ``sensed``: with sensed obstacles, which sensing again
    # may clear). The behaviour tree's recoveries choose by them.
    failure: str | None = None
    proof: str | None = None
    # Lets go of what the plan's searches kept that ``export`` does not read (the world's
    # grids, caches): called once the plan is superseded and its problem still unwritten.
    release: Callable[[], None] = field(default=lambda: None, repr=False, compare=False)

    @cached_property
    def problem_pddl(self) -> str:
        """The PDDL problem this plan solves (written on the first read, then kept)."""
        return self.export()


class PlanningStrategy(Protocol):
    """Plans, checks and executes one mission's plan."""

    name: str

    def replan(
        self, situation: Situation, trigger: Trigger, cancel: CancelFlag | None = None
    ) -> Replanned:
        """A new plan from the situation (the first plan too), recorded with its trigger."""
        ...

    def broken(self, situation: Situation) -> Trigger | None:
        """A trigger if the rest of the plan no longer holds in the situation."""
        ...

    def command(self, situation: Situation) -> Command | Trigger | None:
        """The command for the next tick; a trigger if execution cannot go on; ``None`` when
        the plan is done."""
        ...

    def actions(self) -> list[dict[str, Any]]:
        """The current plan's steps for the API (name, args, primitives, grounding, ...)."""
        ...

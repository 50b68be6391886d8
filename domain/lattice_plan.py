"""A lattice plan: its actions (library primitives between lattice states, goal visits), its
status and reason, and the PDDL problem it solves."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

from domain.goal_order import LegGoal
from domain.lattice import Key, LatticeGrid, MotionTable
from domain.lattice_pddl import LatticeGraph, lattice_problem
from domain.lattice_task import LatticeTask, primitive_name
from domain.pddl import Problem
from domain.pyperplan_adapter import PlanResult
from sim.robot import Array


@dataclass(frozen=True)
class LatticeAction:
    """One step of a plan: a primitive from one lattice state to the next, or a goal visit."""

    name: str  # "move" or "visit"
    pddl: str
    primitive: str | None  # library id of a move
    target: tuple[float, float, float]  # tracked-point pose at the end (x, y, ψ)
    duration: float
    goal: int | None = None  # mission goal index of a visit
    source: Key | None = None  # lattice state the move starts from
    motion: int | None = None  # index of the move's motion in the shape's motion table


@dataclass
class LatticePlan:
    status: str  # solved | unsolvable | unreachable | timeout | cancelled | no-primitives
    reason: str = ""
    actions: list[LatticeAction] = field(default_factory=list)
    order: list[int] = field(default_factory=list)  # mission goal indices in tour order
    expansions: int = 0
    search_ms: float = 0.0
    task: LatticeTask | None = None  # the first leg's task (for the PDDL export)
    legs: list[LatticeTask] = field(default_factory=list)  # every leg's task (the PDDL export)
    partial: bool = False  # the search ran out of time: the plan leads towards the goal only
    graph: LatticeGraph | None = None  # the lattice a repaired plan's problem lists
    repaired: bool = False  # the last plan made free again around a local change
    reachable: bool = False  # the reachability test found the first leg's goal reachable

    def problem(self, shape: str, reshaped_from: str | None = None) -> Problem | None:
        """The PDDL problem this plan solves (the lattice its searches generated), if any."""
        if self.graph is not None:
            return lattice_problem(self.graph, shape, reshaped_from)
        return lattice_problem(self.legs, shape, reshaped_from) if self.legs else None

    def release(self) -> None:
        """Let go of what the legs' searches kept beyond what ``problem`` reads (see
        ``LatticeTask.release``): the plan was superseded."""
        for task in [*self.legs, *([self.task] if self.task else [])]:
            task.release()  # the first leg's task may be among the legs: releasing is idempotent

    @property
    def solved(self) -> bool:
        return self.status == "solved"

    @property
    def pddl_plan(self) -> list[str]:
        return [a.pddl for a in self.actions]

    def result(self) -> PlanResult:
        status = (
            "solved" if self.solved else ("timeout" if self.status == "timeout" else "unsolvable")
        )
        if self.status == "cancelled":
            status = "cancelled"
        return PlanResult(status, self.pddl_plan, self.search_ms, self.expansions, self.reason)  # type: ignore[arg-type]


def unreachable(shape: str, goal: LegGoal, started: float) -> LatticePlan:
    """The plan when no motion of the ``shape`` body can bring its head to ``goal`` (planning
    began at ``started``, ``time.monotonic()``)."""
    done = LatticePlan(
        "unreachable",
        f"unreachable: goal {goal.index} at ({goal.x:g}, {goal.y:g}): no collision-free "
        f"motion of the {shape} body brings its head there",
    )
    done.search_ms = (time.monotonic() - started) * 1e3
    return done


def search_failed(
    result: PlanResult, shape: str, goal: LegGoal, expansions: int, time_limit: float
) -> str:
    """Why a leg's search found no plan, as the user reads it (``expansions``: its budget)."""
    if result.status == "unsolvable":
        return (
            f"unreachable: no collision-free sequence of {shape} primitives brings "
            f"the body to goal {goal.index} at ({goal.x:g}, {goal.y:g})"
        )
    if result.status == "timeout":
        return (
            f"planning timeout: no plan to goal {goal.index} within "
            f"{expansions:,} expansions or {time_limit:g} s"
        )
    return f"planning {result.status}"


def state_pose(grid: LatticeGrid, table: MotionTable, key: Key) -> Array:
    """The tracked-point pose (x, y, ψ) of ``table``'s body at lattice state ``key``."""
    i, j, k = key
    return table.pose_of_centroid(grid.centre(i, j), k)


def plan_actions(
    grid: LatticeGrid, task: LatticeTask, table: MotionTable, names: list[str]
) -> tuple[list[LatticeAction], Key]:
    """A leg's searched operator names (``task``'s) as plan actions, and the state it ends in."""
    by_name = {primitive_name(m.primitive): i for i, m in enumerate(table.motions)}

    def target(key: Key) -> tuple[float, float, float]:
        x, y, psi = state_pose(grid, table, key)
        return float(x), float(y), float(psi)

    here = task.start_key
    out = []
    for name in names:
        verb, *args = name.strip("()").split()
        if verb == "move":
            source, here = here, grid.decode(int(args[1][1:]))
            m = by_name[args[2]]
            motion = table.motions[m]
            out.append(
                LatticeAction(
                    "move", name, motion.primitive, target(here), motion.duration, None, source, m
                )
            )
        else:
            out.append(LatticeAction("visit", name, None, target(here), 0.0, task.goal_index))
    return out, here

"""Navigation on a state lattice of learned primitives: the package's front door.

``app/`` imports from here only. The concepts (each a section of ``docs/navigation.md``):

- the **lattice** (``lattice``): states (centroid cell, heading) and the library's lattice
  primitives as motions, with their swept sample points, lengths and blind cells;
- what a motion **costs** (``lattice.costs``): its length, more near lethal obstacles, plus
  metres per contact it risks by sweeping never-observed space or contact evidence blind;
- the **search** (``search``): weighted A* on those costs with the obstacle heuristic, one
  expansion budget and an anytime best node, compiled, with pyperplan's searches as a check;
- **feasibility** (``feasibility``): the one check that proves a goal unreachable, from the
  lethal layer alone;
- the **planner** (``planner``): ``PlanRequest -> Plan | Failure``;
- the **strategy** (``strategy``): plans and follows a plan through the executor's port;
- the **recoveries**' motions (``recovery``): back off, spin to sense, change shape.
"""

from domain.navigation.feasibility import Feasibility
from domain.navigation.lattice.grid import Key, LatticeGrid, compose, relative
from domain.navigation.lattice.motions import (
    HeadView,
    Motion,
    MotionTable,
    body_key,
    held_joints,
    motion_table,
    primitive_name,
)
from domain.navigation.lattice.pddl import lattice_domain, lattice_domain_text, lattice_problem
from domain.navigation.plan import Failure, Plan, PlanAction, PlanRequest, leg_reach
from domain.navigation.planner import Planner
from domain.navigation.recovery import back_off, reshape_duration, reshape_options, spin
from domain.navigation.search import COST_SEARCH, SEARCH_NAMES
from domain.navigation.settings import (
    CostSettings,
    FollowSettings,
    NavigationSettings,
    RecoverySettings,
    SearchSettings,
)
from domain.navigation.strategy import NavigationStrategy
from domain.navigation.warm import warm_tables

__all__ = [
    "COST_SEARCH",
    "SEARCH_NAMES",
    "CostSettings",
    "Failure",
    "Feasibility",
    "FollowSettings",
    "HeadView",
    "Key",
    "LatticeGrid",
    "Motion",
    "MotionTable",
    "NavigationSettings",
    "NavigationStrategy",
    "Plan",
    "PlanAction",
    "PlanRequest",
    "Planner",
    "RecoverySettings",
    "SearchSettings",
    "back_off",
    "body_key",
    "compose",
    "held_joints",
    "lattice_domain",
    "lattice_domain_text",
    "lattice_problem",
    "leg_reach",
    "motion_table",
    "primitive_name",
    "relative",
    "reshape_duration",
    "reshape_options",
    "spin",
    "warm_tables",
]

"""Peer-checked PDDL: every exported domain and problem parses in unified-planning, Fast
Downward (lama-first) solves it, and our plans and Fast Downward's validate on the same problem.

The lattice checks run on a coarser lattice (0.1 m cells, 32 orientations) in 2 m x 2 m arenas:
unified-planning 1.3 lists every grounding of every predicate when it writes or inspects a
problem (aiplan4eu/unified-planning#689), |states|² x |primitives| for ``succ``, which makes
the full-resolution exports of even small arenas cost it minutes (bench/planning.py shows it).
The exporter is the same at every resolution.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from typing import Any

import pytest

pytest.importorskip("unified_planning")
pytest.importorskip("up_fast_downward")

from unified_planning.engines import PlanGenerationResultStatus, ValidationResultStatus
from unified_planning.io import PDDLReader
from unified_planning.model.metrics import MinimizeSequentialPlanLength
from unified_planning.shortcuts import OneshotPlanner, PlanValidator, get_environment

from domain.goal_order import LegGoal
from domain.lattice import LatticeSettings, motion_table
from domain.lattice_pddl import lattice_domain, lattice_problem
from domain.lattice_plan import LatticePlan
from domain.lattice_planner import LatticePlanner
from domain.pyperplan_adapter import parse_and_ground, search_task, validate_plan
from domain.reactive import ReactiveState, plan_reactive, reactive_domain, reactive_problem
from domain.worldmodel import WorldModel
from primitives.library import load_bundled
from sim.obstacles import Circle
from sim.world import Bounds

get_environment().credits_stream = None  # no engine banners in the test output

LIB = load_bundled()
COARSE = LatticeSettings(resolution=0.1, orientations=32)
ARENA = Bounds(-1.0, 1.0, -1.0, 1.0)
OBSTACLE = Circle(0.0, -0.1, 0.15)
START = (-0.5, 0.6, 0.0)  # the body lies along +x from here, clear of the post
FD_TIME_LIMIT = 120.0
SOLVED = (
    PlanGenerationResultStatus.SOLVED_SATISFICING,
    PlanGenerationResultStatus.SOLVED_OPTIMALLY,
)
UNSOLVABLE = (
    PlanGenerationResultStatus.UNSOLVABLE_PROVEN,
    PlanGenerationResultStatus.UNSOLVABLE_INCOMPLETELY,
)


def read(domain: str, problem: str) -> Any:
    return PDDLReader().parse_problem_string(domain, problem)


def fast_downward(problem: Any, optimal: bool = False) -> Any:
    """lama-first, or A* with LM-cut minimising the plan length (``optimal``)."""
    if optimal:
        problem = problem.clone()
        problem.add_quality_metric(MinimizeSequentialPlanLength())
    name = "fast-downward-opt" if optimal else "fast-downward"
    with OneshotPlanner(name=name) as planner:
        return planner.solve(problem, timeout=FD_TIME_LIMIT)


def names(up_plan: Any) -> list[str]:
    """A unified-planning plan as our operator names, e.g. ``(move s1 s2 lat-x)``."""
    return [
        f"({' '.join([a.action.name, *(str(p) for p in a.actual_parameters)])})"
        for a in up_plan.actions
    ]


def up_valid(problem: Any, plan: Sequence[str]) -> bool:
    """Our plan (operator names) validated by unified-planning's sequential plan validator."""
    parsed = PDDLReader().parse_plan_string(problem, "\n".join(plan))
    with PlanValidator(name="sequential_plan_validator") as validator:
        result = validator.validate(problem, parsed)
    return bool(result.status == ValidationResultStatus.VALID)


# -- the reactive domain (paper Table 3) --------------------------------------------------------


@pytest.mark.parametrize(
    "flags",
    list(itertools.product((False, True), repeat=4)),
    ids=lambda f: "".join("FT"[v] for v in f),
)
def test_every_reactive_state_is_solved_alike_by_fast_downward(flags: tuple[bool, ...]) -> None:
    state = ReactiveState(*flags)
    domain, problem_text = reactive_domain().text(), reactive_problem(state, "straight").text()
    problem = read(domain, problem_text)
    assert {a.name for a in problem.actions} == {"po1", "po2", "po3"}
    ours, _ = plan_reactive(state, "straight")
    lama = fast_downward(problem)
    if not ours.solved:  # boxed in: the peer agrees there is no plan
        assert ours.status == "unsolvable"
        assert lama.status in UNSOLVABLE, lama.status
        return
    assert lama.status in SOLVED, lama.status
    theirs = names(lama.plan)
    assert up_valid(problem, ours.plan)
    assert up_valid(problem, theirs)
    # Fast Downward's plan is valid on pyperplan's grounding of the same text too.
    assert validate_plan(parse_and_ground(domain, problem_text), theirs) == (True, "valid")
    # Ours is optimal here (an optimal peer finds no shorter plan); lama-first's is no shorter.
    optimal = fast_downward(problem, optimal=True)
    assert optimal.status == PlanGenerationResultStatus.SOLVED_OPTIMALLY
    assert len(ours.plan) == len(optimal.plan.actions)
    assert len(theirs) >= len(ours.plan)


def test_reactive_problems_with_every_library_shape_parse() -> None:
    shapes = tuple(LIB.shapes())
    text = reactive_problem(ReactiveState(obstacle_togoal=True), shapes[0], shapes).text()
    problem = read(reactive_domain().text(), text)
    assert {o.name for o in problem.all_objects} >= set(shapes)
    assert up_valid(problem, [f"(po2 {shapes[0]})", f"(po1 {shapes[0]})"])
    assert not up_valid(problem, [f"(po1 {shapes[0]})"])  # the validator does reject


# -- the navigation lattice -----------------------------------------------------------------------


def lattice_plan(goals: Sequence[tuple[float, float]], shape: str = "straight") -> LatticePlan:
    table = motion_table(LIB, shape, (0.0, 0.0, 0.0), COARSE)
    assert table is not None
    world = WorldModel(ARENA, [OBSTACLE])
    legs = [LegGoal(i, x, y, 0.1) for i, (x, y) in enumerate(goals)]
    planner = LatticePlanner(ARENA, COARSE, time_limit=60.0)
    plan = planner.plan(table, world.clearance_at, world.version, START, legs, ordered=False)
    assert plan.solved and not plan.partial, plan.reason
    assert len(plan.legs) == len(goals)
    return plan


@pytest.mark.slow
@pytest.mark.parametrize(
    ("goals", "shape"),
    [
        ([(-0.6, -0.6)], "straight"),
        ([(-0.6, -0.6)], "semi-zigzag"),
        ([(-0.6, -0.6), (-0.2, -0.7)], "straight"),  # several unordered goals: one tour
    ],
    ids=["one-goal", "one-goal-semi-zigzag", "two-goals"],
)
def test_lattice_exports_parse_and_fast_downward_agrees(
    goals: list[tuple[float, float]], shape: str
) -> None:
    plan = lattice_plan(goals, shape)
    domain, problem_text = lattice_domain().text(), lattice_problem(plan.legs, shape).text()
    problem = read(domain, problem_text)
    assert len(problem.goals) == 1 and problem.goals[0].is_and() == (len(goals) > 1)
    assert up_valid(problem, plan.pddl_plan)  # the whole tour, on the exported problem
    lama = fast_downward(problem)
    assert lama.status in SOLVED, lama.status
    theirs = names(lama.plan)
    assert up_valid(problem, theirs)
    grounded = parse_and_ground(domain, problem_text)
    assert validate_plan(grounded, theirs) == (True, "valid")
    visited = {n.split()[2].rstrip(")") for n in theirs if n.startswith("(visit ")}
    assert visited == {f"g{i}" for i in range(len(goals))}
    # Neither ours (greedy, leg by leg) nor lama-first is optimal; both are no shorter than
    # the optimum, on which an optimal Fast Downward and pyperplan's blind A* agree.
    optimal = fast_downward(problem, optimal=True)
    assert optimal.status == PlanGenerationResultStatus.SOLVED_OPTIMALLY
    shortest = search_task(grounded, "astar", "blind", time_limit=60)
    assert shortest.solved and len(shortest.plan) == len(optimal.plan.actions)
    assert len(plan.pddl_plan) >= len(shortest.plan) <= len(theirs)


def test_a_broken_plan_is_rejected_by_the_peer_validator() -> None:
    plan = lattice_plan([(-0.6, -0.6)])
    problem = read(lattice_domain().text(), lattice_problem(plan.legs, "straight").text())
    moves = plan.pddl_plan
    assert not up_valid(problem, moves[:-1])  # stops short of the visit
    assert not up_valid(problem, [moves[1], moves[0], *moves[2:]])  # out of order

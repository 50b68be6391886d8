"""The lattice's PDDL: with ``:action-costs`` (each move at its cost in whole millimetres, the
total cost minimised), and the same domain and problem as plain STRIPS for pyperplan; what the
searches generated grounds to the operators they generated, a plan is valid on its export and
pyperplan's own search solves the plain text."""

from __future__ import annotations

import math
import re

import pytest

from domain.navigation import (
    NavigationSettings,
    Planner,
    lattice_domain,
    lattice_domain_text,
    lattice_problem,
    motion_table,
)
from domain.navigation.lattice.pddl import millimetres
from domain.pyperplan_adapter import PlanningError, parse_and_ground, search_task, validate_plan
from domain.world import CostmapSettings, WorldModel
from sim.obstacles import Circle
from sim.world import Bounds
from tests.domain.lattice_scenes import LIB, legs, plan, solved

COARSE = NavigationSettings(
    resolution=0.1, orientations=32, costmap=CostmapSettings(resolution=0.1)
)
TABLE = motion_table(LIB, "straight", (0.0, 0.0, 0.0), COARSE)
# Whole-lattice groundings (the export check) stay smaller still.
COARSER = NavigationSettings(
    resolution=0.2, orientations=16, costmap=CostmapSettings(resolution=0.2)
)
COARSER_TABLE = motion_table(LIB, "straight", (0.0, 0.0, 0.0), COARSER)
ARENA = Bounds(-1.0, 1.0, -1.0, 1.0)
POST = Circle(0.0, -0.1, 0.15)
START = (-0.5, 0.6, 0.0)  # the body lies along +x from here, clear of the post


def operator_table(operators) -> set:
    def names(facts):
        return frozenset(str(f) for f in facts)

    return {
        (o.name, names(o.preconditions), names(o.add_effects), names(o.del_effects))
        for o in operators
    }


def coarse_plan(goals, ordered=True):
    assert TABLE is not None
    _, _, out = plan(ARENA, [POST], START, goals, ordered, table=TABLE, settings=COARSE)
    return solved(out)


def move_costs(problem_text: str) -> dict[str, int]:
    """The problem's move costs by the move's operator name."""
    found = re.findall(r"\(= \(move-cost (s\d+) (s\d+) (\S+)\) (\d+)\)", problem_text)
    return {f"(move {a} {b} {p})": int(c) for a, b, p, c in found}


def test_the_export_carries_action_costs_and_a_metric() -> None:
    result = coarse_plan([(-0.6, -0.6)])
    domain, problem = lattice_domain_text(), result.problem()
    assert problem is not None
    text = problem.text()
    assert ":action-costs" in domain and "(increase (total-cost) (move-cost ?a ?b ?p))" in domain
    assert "(= (total-cost) 0)" in text and "(:metric minimize (total-cost))" in text
    costs = move_costs(text)
    assert len(costs) == text.count("(succ ")  # every successor listed has its cost
    # Each move of the plan is listed at its cost in millimetres; the plan costs their sum.
    moves = [a for a in result.actions if a.name == "move"]
    assert [costs[a.pddl] for a in moves] == [millimetres(a.cost) for a in moves]
    assert sum(costs[a.pddl] for a in moves) == pytest.approx(1000 * result.cost, abs=len(moves))
    assert millimetres(0.0) == 1 and millimetres(0.2494) == 249


def test_plain_strips_text_parses_with_pyperplan_and_the_plan_validates() -> None:
    result = coarse_plan([(-0.6, -0.6)])
    problem = result.problem()
    assert problem is not None
    plain_domain, plain_problem = lattice_domain_text(costs=False), problem.text(costs=False)
    assert "total-cost" not in plain_domain + plain_problem
    assert ":action-costs" not in plain_domain
    task = parse_and_ground(plain_domain, plain_problem)
    assert validate_plan(task, result.pddl_plan) == (True, "valid")
    assert not validate_plan(task, result.pddl_plan[:-1])[0]  # stops short of the visit
    again = search_task(task, "astar", "blind", time_limit=60)
    assert again.solved and validate_plan(task, again.plan) == (True, "valid")
    # pyperplan does not read action costs: the costed text is for planners that do.
    with pytest.raises(PlanningError, match="parse"):
        parse_and_ground(lattice_domain_text(), problem.text())


def test_direct_grounding_equals_pyperplans_grounding_of_the_export() -> None:
    """The whole reachable lattice of a small arena, grounded by the task itself, equals
    pyperplan's grounding of its plain STRIPS export, operator for operator."""
    table = COARSER_TABLE
    assert table is not None
    world = WorldModel(ARENA, [Circle(0.7, 0.7, 0.15)], COARSER.costmap)
    p = Planner(ARENA, COARSER)
    inputs = p.inputs(world, table)
    cache = p.cache(table, world, inputs)
    start = (5, 5, 0)  # the centroid mid-arena, heading 0
    task = p.task(table, inputs, cache, start, legs([(0.3, 0.0)])[0], True, math.inf, None)
    task.ground_all()
    assert len(task.operators) > 100
    problem = lattice_problem(task, "straight").text(costs=False)
    # Without relevance pruning (pyperplan drops the moves into dead ends by default).
    theirs = parse_and_ground(lattice_domain_text(costs=False), problem, remove_irrelevant=False)
    assert operator_table(task.operators) == operator_table(theirs.operators)
    assert {str(f) for f in task.initial_state} == {str(f) for f in theirs.initial_state}
    assert {str(f) for f in task.goals} == {str(f) for f in theirs.goals}


def test_a_tours_export_grounds_to_every_legs_operators_and_all_its_goals() -> None:
    result = coarse_plan([(-0.6, -0.6), (-0.2, -0.7)], ordered=False)
    assert len(result.legs) == 2
    problem = result.problem()
    assert problem is not None
    exported = parse_and_ground(
        lattice_domain_text(costs=False), problem.text(costs=False), remove_irrelevant=False
    )
    direct: set = set()
    for leg in result.legs:  # what each leg's search generated
        for a, edges in leg.edges.items():
            for b, primitive, _ in edges:
                direct.add(f"(move s{a} s{b} {primitive})")
        direct |= {f"(visit s{s} g{leg.goal_index})" for s in leg.near}
    assert {o.name for o in exported.operators} == direct
    assert {str(f) for f in exported.goals} == {"(visited g0)", "(visited g1)"}
    assert validate_plan(exported, result.pddl_plan) == (True, "valid")


def test_an_export_needs_a_leg() -> None:
    with pytest.raises(ValueError, match="at least one leg"):
        lattice_problem([], "straight")


def test_the_domain_names_no_type_as_a_predicate() -> None:
    """unified-planning rejects a name used as both a type and a predicate."""
    domain = lattice_domain()
    predicates = {p.strip("(").split()[0] for p in domain.predicates}
    assert not predicates & set(domain.types)
    assert lattice_domain_text(costs=False) == domain.text(costs=False)

"""The export of a tour: pyperplan's grounding of it equals the legs' direct groundings together."""

import pytest

from domain.goal_order import LegGoal
from domain.lattice import LatticeSettings, motion_table
from domain.lattice_pddl import lattice_domain, lattice_problem
from domain.lattice_planner import LatticePlanner
from domain.pyperplan_adapter import parse_and_ground, validate_plan
from domain.worldmodel import WorldModel
from primitives.library import load_bundled
from sim.obstacles import Circle
from sim.world import Bounds
from tests.domain.test_lattice import operator_table

COARSE = LatticeSettings(resolution=0.1, orientations=32)
TABLE = motion_table(load_bundled(), "straight", (0.0, 0.0, 0.0), COARSE)


def test_a_tours_export_grounds_to_every_legs_operators_and_all_its_goals() -> None:
    bounds = Bounds(-1.0, 1.0, -1.0, 1.0)
    world = WorldModel(bounds, [Circle(0.0, -0.1, 0.15)])
    assert TABLE is not None
    goals = [LegGoal(0, -0.6, -0.6, 0.1), LegGoal(1, -0.2, -0.7, 0.1)]
    plan = LatticePlanner(bounds, COARSE).plan(
        TABLE, world.clearance_at, world.version, (-0.5, 0.6, 0.0), goals, ordered=False
    )
    assert plan.solved and len(plan.legs) == 2
    exported = parse_and_ground(
        lattice_domain().text(),
        lattice_problem(plan.legs, "straight").text(),
        remove_irrelevant=False,
    )
    direct = set().union(*(operator_table(leg.operators_seen()) for leg in plan.legs))
    assert operator_table(exported.operators) == direct
    first = plan.legs[0]
    assert {str(f) for f in exported.initial_state} == {str(f) for f in first.initial_state}
    assert {str(f) for f in exported.goals} == {"(visited g0)", "(visited g1)"}
    assert validate_plan(exported, plan.pddl_plan) == (True, "valid")


def test_an_export_needs_a_leg() -> None:
    with pytest.raises(ValueError, match="at least one leg"):
        lattice_problem([], "straight")

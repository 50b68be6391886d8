"""Local repair: a plan blocked by something newly sensed ahead is repaired round it (few
expansions, the far part kept) into a valid plan whose export pyperplan solves; an unchanged
world keeps the plan without searching; changed goals and a way cut off are planned afresh (the
latter proved unreachable); the strategy repairs for what the sensors found, not for a contact."""

from __future__ import annotations

import itertools
import math

import numpy as np

from domain.goal_order import LegGoal
from domain.navigation import (
    Failure,
    NavigationStrategy,
    Plan,
    Planner,
    PlanRequest,
    lattice_domain_text,
)
from domain.navigation.repair import plan_steps
from domain.pyperplan_adapter import parse_and_ground, search_task, validate_plan
from domain.strategy import Situation
from domain.triggers import Contact, Initial, PathBlocked
from domain.world import RangeObservation, WorldModel
from sim.obstacles import Circle, rectangle
from sim.world import Bounds
from tests.domain.lattice_scenes import (
    LIB,
    SETTINGS,
    STRAIGHT,
    ahead,
    legs,
    looked_round,
    move_slack,
    sense_post,
    solved,
)

BOUNDS = Bounds(-3, 3, -3, 3)
OBSTACLES = [Circle(0.0, 0.8, 0.3), Circle(-1.0, -0.6, 0.25)]
START, GOAL = (2.2, -2.0, math.pi), (-2.2, 2.0)
GOALS = legs([GOAL])


def first_plan(obstacles=OBSTACLES, start=START, goals=GOALS) -> tuple[Planner, WorldModel, Plan]:
    world = looked_round(WorldModel(BOUNDS, obstacles, SETTINGS.costmap))
    p = Planner(BOUNDS, SETTINGS)
    first = solved(p.plan(PlanRequest(start, STRAIGHT, goals, True, world)))
    assert not first.partial
    return p, world, first


def advance(first: Plan, n: int) -> tuple[tuple[float, float, float], list]:
    """The robot after the first ``n`` moves: its pose and what remains of the plan."""
    moves = [a for a in first.actions if a.name == "move"]
    return moves[n - 1].target, first.actions[first.actions.index(moves[n - 1]) + 1 :]


def assert_valid_from(p: Planner, world: WorldModel, result: Plan, pose) -> None:
    """The plan starts at the robot's state, its moves chain, every move after the first keeps
    the margin from the lethal layer now (known and sensed), none touches a known obstacle,
    and it ends visiting the goal."""
    steps = plan_steps(result.actions)
    assert steps and steps[0].state == p.grid.encode(p.key_of(STRAIGHT, pose))
    assert all(a.after == b.state for a, b in itertools.pairwise(steps))
    move_slack(p, STRAIGHT, result, BOUNDS, OBSTACLES)  # library sweeps touch nothing known
    moves = [a for a in result.actions if a.name == "move"]
    for a in moves[1:]:
        assert a.source is not None and a.motion is not None
        i, j, k = a.source
        seg = STRAIGHT.segments[k]
        hi = int(seg[a.motion + 1]) if a.motion + 1 < len(seg) else len(STRAIGHT.points[k])
        points = p.grid.centre(i, j) + STRAIGHT.points[k][seg[a.motion] : hi]
        needs = STRAIGHT.needs[k][seg[a.motion] : hi] + SETTINGS.margin
        assert np.all(world.clearance_at(points) >= needs - 1e-9), a.pddl
    last = result.actions[-1]
    assert last.name == "visit" and last.goal == 0
    assert math.dist(last.target[:2], GOAL) <= 0.06


def replanned_after_a_post_sensed_ahead() -> tuple[Planner, WorldModel, tuple, list, Plan]:
    """Two moves along the first plan, a post sensed on it a metre further, a replan with the
    rest of the plan."""
    p, world, first = first_plan()
    pose, remaining = advance(first, 2)
    x, y = ahead([a for a in remaining if a.name == "move"], pose)
    sense_post(world, x, y)
    previous = Plan(remaining, shape="straight")
    result = p.plan(PlanRequest(pose, STRAIGHT, GOALS, True, world, previous))
    return p, world, pose, remaining, solved(result)


def test_a_post_sensed_on_the_path_is_repaired_round_locally() -> None:
    p, world, pose, remaining, result = replanned_after_a_post_sensed_ahead()
    assert result.repaired and not result.partial
    assert 0 < result.expansions <= SETTINGS.search.repair_expansions
    assert result.actions != remaining  # the blocked moves were replaced ...
    assert result.actions[-10:] == remaining[-10:]  # ... and the far part kept as it was
    assert_valid_from(p, world, result, pose)


def test_a_repaired_plan_solves_its_export_and_pyperplan_solves_it_again() -> None:
    *_, result = replanned_after_a_post_sensed_ahead()
    problem = result.problem()
    assert problem is not None and "repaired" in problem.text()
    task = parse_and_ground(lattice_domain_text(costs=False), problem.text(costs=False))
    assert validate_plan(task, result.pddl_plan) == (True, "valid")
    again = search_task(task, "astar", "blind", time_limit=30)
    assert again.solved and validate_plan(task, again.plan) == (True, "valid")


def test_an_unchanged_world_keeps_the_plan_without_searching() -> None:
    p, world, first = first_plan()
    pose, remaining = advance(first, 3)
    previous = Plan(remaining, shape="straight")
    result = solved(p.plan(PlanRequest(pose, STRAIGHT, GOALS, True, world, previous)))
    assert result.repaired and result.expansions == 0
    assert result.actions == remaining


def test_changed_goals_are_planned_afresh() -> None:
    p, world, first = first_plan()
    pose, remaining = advance(first, 3)
    other = (LegGoal(0, 2.0, 2.2, 0.1),)
    previous = Plan(remaining, shape="straight")
    result = solved(p.plan(PlanRequest(pose, STRAIGHT, other, True, world, previous)))
    assert not result.repaired
    assert math.dist(result.actions[-1].target[:2], (2.0, 2.2)) <= 0.06


def test_a_way_cut_off_is_not_repaired_but_found_unreachable() -> None:
    """A wall across the arena with one gap; the plan goes through it, then the gap is sensed
    shut: no detour exists, and the full plan proves it (by what was sensed)."""
    wall = [rectangle(-1.6, 0.0, 2.8, 0.2), rectangle(1.6, 0.0, 2.8, 0.2)]
    world = WorldModel(BOUNDS, wall, SETTINGS.costmap)
    p = Planner(BOUNDS, SETTINGS)
    goals = legs([(0.0, 2.2)])
    first = solved(p.plan(PlanRequest((0.0, -2.0, -math.pi / 2), STRAIGHT, goals, True, world)))
    for _ in range(3):  # rays from the south echoing on a line across the gap
        world.integrate(
            RangeObservation((float(x), -0.6), math.pi / 2, 0.0, 1.0, 0.5, True)
            for x in np.arange(-0.25, 0.26, 0.025)
        )
    pose, remaining = advance(first, 1)
    previous = Plan(remaining, shape="straight")
    result = p.plan(PlanRequest(pose, STRAIGHT, goals, True, world, previous))
    assert isinstance(result, Failure)
    assert (result.kind, result.proof, result.goal) == ("unreachable", "sensed", 0)


def situation(world: WorldModel, pose) -> Situation:
    return Situation(0.0, pose, (0.0, 0.0, 0.0), "straight", GOALS, True, world)


def test_the_strategy_repairs_for_what_the_sensors_found_and_plans_anew_after_a_contact() -> None:
    world = looked_round(WorldModel(BOUNDS, OBSTACLES, SETTINGS.costmap))
    strategy = NavigationStrategy(LIB, Planner(BOUNDS, SETTINGS))
    first = strategy.replan(situation(world, START), Initial())
    assert first.ok and strategy.plan is not None
    moves = [a for a in strategy.plan.actions if a.name == "move"]
    here = moves[1].target  # two moves on
    x, y = ahead(moves[2:], here)
    sense_post(world, x, y)
    blocked = strategy.broken(situation(world, here))
    assert isinstance(blocked, PathBlocked)
    repaired = strategy.replan(situation(world, here), blocked)
    assert repaired.ok and repaired.reason == "repaired"
    assert repaired.record.trigger == "path_blocked"
    touched = strategy.replan(situation(world, here), Contact(3, "left", (x, y)))
    assert touched.ok and touched.reason == "" and strategy.plan is not None
    assert not strategy.plan.repaired

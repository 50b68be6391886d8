"""Local plan repair: after a local change the remaining plan is made free again around it,
the result is a valid, collision-free plan whose export other planners solve, and whatever a
repair cannot do is left to a full plan."""

import itertools
import math

import numpy as np

from domain.goal_order import LegGoal
from domain.lattice_pddl import lattice_domain
from domain.lattice_repair import moves_free, plan_steps
from domain.lattice_task import LatticeTask, start_allowance
from domain.pyperplan_adapter import parse_and_ground, search_task, validate_plan
from sim.obstacles import Circle, rectangle
from sim.world import Bounds
from tests.domain.test_lattice import STRAIGHT, plan

BOUNDS = Bounds(-3, 3, -3, 3)
OBSTACLES = [Circle(0.0, 0.8, 0.3), Circle(-1.0, -0.6, 0.25)]
START, GOAL = (2.2, -2.0, math.pi), (-2.2, 2.0)
LEGS = [LegGoal(0, *GOAL, 0.1)]


def first_plan():
    p, world, first = plan(BOUNDS, OBSTACLES, START, [GOAL])
    assert first.solved and not first.partial and STRAIGHT is not None
    return p, world, first


def advance(first, n):
    """The robot after the first ``n`` moves: its pose and what remains of the plan."""
    moves = [a for a in first.actions if a.name == "move"]
    return moves[n - 1].target, first.actions[first.actions.index(moves[n - 1]) + 1 :]


def assert_valid_from(p, world, result, pose):
    """The plan starts at the robot's state, its moves chain, every move keeps its margin and
    it ends visiting the goal."""
    assert STRAIGHT is not None
    steps = plan_steps(p.grid, result.actions)
    assert steps
    start = p.key_of(STRAIGHT, pose)
    assert steps[0].state == p.grid.encode(start)
    assert all(a.after == b.state for a, b in itertools.pairwise(steps))
    moves = [s for s in steps if s.motion is not None]
    allowance = start_allowance(
        p.grid, STRAIGHT, world.clearance_at, start, p.settings.start_margin
    )
    margins = [allowance if s.state == steps[0].state else p.settings.margin for s in moves]
    assert moves_free(
        p.grid, STRAIGHT, world.clearance_at, [(s.state, s.motion) for s in moves], margins
    ).all()
    last = result.actions[-1]
    assert last.name == "visit" and last.goal == 0
    assert math.dist(last.target[:2], GOAL) <= 0.06


def replanned_after_an_obstacle_ahead():
    """Two moves along the first plan, something found six moves further, a replan."""
    p, world, first = first_plan()
    pose, remaining = advance(first, 2)
    ahead = [a for a in remaining if a.name == "move"][6].target
    world.add_contact((ahead[0], ahead[1]))
    assert STRAIGHT is not None
    result = p.plan(
        STRAIGHT, world.clearance_at, world.version, pose, LEGS, True, previous=remaining
    )
    return p, world, pose, remaining, result


def test_an_obstacle_found_on_the_path_is_repaired_around_locally() -> None:
    p, world, pose, remaining, result = replanned_after_an_obstacle_ahead()
    assert result.solved and result.repaired
    assert 0 < result.expansions < 150
    assert_valid_from(p, world, result, pose)
    # The far part of the old plan is kept as it was.
    assert result.actions[-10:] == remaining[-10:]


def test_a_repaired_plan_solves_its_export_and_pyperplan_solves_it_again() -> None:
    *_, result = replanned_after_an_obstacle_ahead()
    assert result.repaired
    problem = result.problem("straight")
    assert problem is not None and "repaired" in problem.text()
    task = parse_and_ground(lattice_domain().text(), problem.text())
    assert validate_plan(task, result.pddl_plan) == (True, "valid")
    assert search_task(task, "gbf", "hff", time_limit=30).solved


def test_an_unchanged_world_keeps_the_plan_without_searching() -> None:
    p, world, first = first_plan()
    pose, remaining = advance(first, 3)
    assert STRAIGHT is not None
    result = p.plan(
        STRAIGHT, world.clearance_at, world.version, pose, LEGS, True, previous=remaining
    )
    assert result.repaired and result.expansions == 0
    assert result.actions == remaining


def test_changed_goals_are_planned_afresh() -> None:
    p, world, first = first_plan()
    pose, remaining = advance(first, 3)
    assert STRAIGHT is not None
    other = [LegGoal(0, 2.0, 2.2, 0.1)]
    result = p.plan(
        STRAIGHT, world.clearance_at, world.version, pose, other, True, previous=remaining
    )
    assert result.solved and not result.repaired
    assert math.dist(result.actions[-1].target[:2], (2.0, 2.2)) <= 0.06


def test_a_way_cut_off_is_not_repaired_but_found_unreachable() -> None:
    # A wall across the arena with one gap; the plan goes through it, then the gap is felt shut.
    wall = [rectangle(-1.6, 0.0, 2.8, 0.2), rectangle(1.6, 0.0, 2.8, 0.2)]
    p, world, first = plan(BOUNDS, wall, (0.0, -2.0, -math.pi / 2), [(0.0, 2.2)])
    assert first.solved and STRAIGHT is not None
    for x in np.arange(-0.25, 0.26, 0.05):
        world.add_contact((float(x), 0.0))
    pose, remaining = advance(first, 1)
    result = p.plan(
        STRAIGHT,
        world.clearance_at,
        world.version,
        pose,
        [LegGoal(0, 0.0, 2.2, 0.1)],
        True,
        previous=remaining,
    )
    assert not result.solved and not result.repaired
    assert result.status == "unreachable"


def test_motions_kept_by_a_repair_equal_a_fresh_check() -> None:
    p, world, *_, result = replanned_after_an_obstacle_ahead()
    assert result.repaired
    cache = p.motion_cache(STRAIGHT)
    m = p.settings.margin
    fresh = LatticeTask(p.grid, STRAIGHT, world.clearance_at, (0, 0, 0), GOAL, 0.06, m, m)
    fresh.start_key = (-1, -1, -1)  # no state is the start: every one checked in full
    for number, kept in cache.free.items():
        ok = np.zeros(len(STRAIGHT.motions), dtype=bool)
        ok[[m for _, m in fresh.valid_motions(p.grid.decode(number))]] = True
        assert np.array_equal(kept, ok), p.grid.decode(number)

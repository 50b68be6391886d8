"""Navigation domain: grounding, valid plans, export, determinism, limits, replanning."""

import os
import re
import subprocess
import sys
import threading

import numpy as np
import pytest

from domain.knowledge import Goal, WorldKnowledge
from domain.navigation import HEADINGS, NavigationPlanner
from domain.pddl import heading_name
from domain.pyperplan_adapter import (
    IndexedTask,
    PlanningError,
    parse_and_ground,
    plan_pddl,
    search_task,
)
from domain.replanner import Replanner, naive_replan
from domain.triggers import GoalsChanged, NoProgress, ObstacleSensed, ShapeChanged
from primitives.library import load_bundled
from sim.obstacles import Circle, rectangle
from sim.world import Bounds

LIB = load_bundled()
SMALL = Bounds(-4, 4, -4, 4)


def knowledge(goals, order="any", shape="straight", known=(), pose=(0.0, 0.0, 0.0), bounds=SMALL):
    return WorldKnowledge(
        pose, shape, tuple(Goal(*g) for g in goals), order, tuple(known), (), bounds
    )


def assert_valid(planner: NavigationPlanner, plan) -> None:
    assert plan.result.solved, plan.result.reason
    assert planner.validate(plan) == (True, "valid")


def operator_table(task: IndexedTask) -> set:
    def names(facts):
        return frozenset(str(f) for f in facts)

    return {
        (o.name, names(o.preconditions), names(o.add_effects), names(o.del_effects))
        for o in task.operators
    }


@pytest.mark.parametrize("order", ["any", "given"])
def test_direct_grounding_equals_pyperplans(order) -> None:
    k = knowledge([(3, 2), (-3, 3)], order, known=(Circle(1.5, 1, 0.5),))
    planner = NavigationPlanner(k, LIB, spacing=1.0)
    planner.plan(k)
    theirs = parse_and_ground(*planner.export())
    assert operator_table(planner.task) == operator_table(theirs)
    assert {str(f) for f in theirs.goals} == {str(f) for f in planner.task.goals}


def test_plan_visits_every_goal_and_maps_back_to_primitives() -> None:
    k = knowledge([(3, 2), (-3, 3), (2, -3)], known=(Circle(1.5, 1, 0.5), rectangle(-1, -2, 1, 1)))
    planner = NavigationPlanner(k, LIB, spacing=0.5)
    plan = planner.plan(k)
    assert_valid(planner, plan)
    visits = [a for a in plan.actions if a.name == "visit"]
    assert sorted(a.goal for a in visits) == [0, 1, 2]
    moves = [a for a in plan.actions if a.name == "move"]
    for a in moves:
        assert a.shape == "straight" and a.heading in HEADINGS and a.target is not None
        assert a.grounding["method"] in ("library", "interpolated")
        assert all(p in LIB for p in a.grounding["primitives"])
    # consecutive targets are at most one diagonal grid step apart: a real path
    pts = np.array([a.target for a in moves])
    assert np.all(np.linalg.norm(np.diff(pts, axis=0), axis=-1) <= 0.5 * np.sqrt(2) + 1e-9)


def test_paths_keep_clear_of_known_obstacles() -> None:
    wall = rectangle(0, 0, 0.4, 5)
    k = knowledge([(3, 0)], known=(wall,), pose=(-3, 0, 0))
    planner = NavigationPlanner(k, LIB, spacing=0.5, inflation=0.3)
    plan = planner.plan(k)
    assert_valid(planner, plan)
    pts = np.array([[-3, 0]] + [a.target for a in plan.actions if a.name == "move"])
    assert np.all(wall.segment_clearance(pts[:-1], pts[1:]) >= 0.3)


def test_given_order_is_respected_and_any_order_is_shorter() -> None:
    goals = [(3, 3), (-3, -3), (3.2, 2.5)]
    lengths = {}
    for order in ("given", "any"):
        k = knowledge(goals, order)
        planner = NavigationPlanner(k, LIB, spacing=0.5)
        plan = planner.plan(k)
        assert_valid(planner, plan)
        reached = [a.goal for a in plan.actions if a.goal is not None]
        if order == "given":
            assert reached == [0, 1, 2]
        lengths[order] = len(plan.actions)
    assert lengths["any"] < lengths["given"]


def test_exported_pddl_is_portable_and_solves_with_pyperplan_astar_lmcut() -> None:
    k = knowledge([(1.5, 1.5)], known=(Circle(-0.8, 0.8, 0.3),), bounds=Bounds(-2, 2, -2, 2))
    planner = NavigationPlanner(k, LIB, spacing=0.5)
    ours = planner.plan(k)
    assert_valid(planner, ours)
    domain, problem = planner.export()
    for name in re.findall(r"\b(?:w|g|s|h_)[a-z0-9_]*\b", problem):
        assert re.fullmatch(r"[a-z][a-z0-9_-]*", name)
    _, result = plan_pddl(domain, problem, "astar", "lmcut", time_limit=60)
    assert result.solved and len(result.plan) <= len(ours.result.plan)
    assert planner.validate(ours)[0]


def test_plans_do_not_depend_on_the_hash_seed() -> None:
    code = (
        "from tests.domain.test_navigation import *\n"
        "k = knowledge([(3, 2), (-3, 3), (2, -3)], known=(Circle(1.5, 1, 0.5),))\n"
        "p = NavigationPlanner(k, LIB, spacing=1.0, heuristic='hff')\n"
        "print(p.plan(k).pddl_plan)\n"
    )
    outputs = set()
    for seed in ("1", "2", "3"):
        env = {**os.environ, "PYTHONHASHSEED": seed}
        outputs.add(
            subprocess.run(
                [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
            ).stdout
        )
    assert len(outputs) == 1


def test_time_limit_and_cancellation_end_the_search() -> None:
    k = knowledge([(8, 8), (-8, 8), (8, -8), (-8, -8)], bounds=Bounds(-10, 10, -10, 10))
    planner = NavigationPlanner(k, LIB, spacing=0.5, heuristic="hff", time_limit=0.05)
    plan = planner.plan(k)
    assert plan.result.status == "timeout" and "timeout" in plan.result.reason
    cancel = threading.Event()
    cancel.set()
    planner.time_limit = 60
    assert planner.plan(k, cancel).result.status == "cancelled"


def test_unreachable_goal_is_reported_with_its_reason() -> None:
    box = [rectangle(2.5, 2.5 + dy, 2.0, 0.3) for dy in (-1, 1)] + [
        rectangle(2.5 + dx, 2.5, 0.3, 2.0) for dx in (-1, 1)
    ]
    k = knowledge([(-2, -2), (2.5, 2.5)], known=tuple(box))
    plan = NavigationPlanner(k, LIB, spacing=0.5).plan(k)
    assert plan.result.status == "unsolvable"
    assert "goal 1 at (2.5, 2.5) cannot be reached" in plan.result.reason


def test_bad_search_or_heuristic_names_are_clear_errors() -> None:
    k = knowledge([(1, 1)])
    with pytest.raises(PlanningError, match="search"):
        NavigationPlanner(k, LIB, search="dfs")
    with pytest.raises(PlanningError, match="heuristic"):
        NavigationPlanner(k, LIB, heuristic="magic")
    with pytest.raises(PlanningError, match="parse"):
        parse_and_ground("(define (domain", "(define")


def test_replanning_after_each_trigger_type() -> None:
    k = knowledge([(3, 0), (3, 3)], order="given", pose=(-3, 0, 0))
    planner = NavigationPlanner(k, LIB, spacing=0.5)
    replanner = Replanner(planner)
    first, rec = replanner.plan(k)
    assert_valid(planner, first)
    assert rec.trigger == "initial"
    # an obstacle sensed on the planned path: the new plan goes around it
    moves = [a for a in first.actions if a.name == "move"]
    bx, by = moves[len(moves) // 4].target
    block = Circle(bx, by, 0.6)
    k = k.with_sensed(block)
    plan, rec = replanner.plan(k, ObstacleSensed(block), at=12.0)
    assert_valid(planner, plan)
    assert rec.trigger == "obstacle_sensed" and rec.old == first.pddl_plan and rec.new != rec.old
    pts = np.array([[-3, 0]] + [a.target for a in plan.actions if a.name == "move"])
    assert np.all(block.segment_clearance(pts[:-1], pts[1:]) >= planner.roadmap.inflation)
    # no progress: replan from where the robot is now
    k = k.moved((-1.0, 1.5, 0.3))
    plan, rec = replanner.plan(k, NoProgress(plan.pddl_plan[0]), at=20.0)
    assert_valid(planner, plan)
    assert rec.trigger == "no_progress"
    assert plan.actions[0].args[0] == "s0"
    # the body deforms into the periodic gait's shape: only headings it can ground remain
    from dataclasses import replace

    k = replace(k, shape="periodic")
    plan, rec = replanner.plan(k, ShapeChanged("periodic"), at=30.0)
    assert rec.trigger == "shape_changed"
    if plan.result.solved:
        assert_valid(planner, plan)
        assert all(a.shape == "periodic" for a in plan.actions if a.name == "move")
        assert {heading_name(h) for h in planner.headings} >= {
            a.args[2] for a in plan.actions if a.name == "move"
        }
    # a goal reached and removed: fewer goals to visit
    k = replace(k, shape="straight", goals=k.goals[1:])
    plan, rec = replanner.plan(k, GoalsChanged(removed=(Goal(3, 0),)), at=40.0)
    assert_valid(planner, plan)
    assert [a.goal for a in plan.actions if a.goal is not None] == [0]
    assert [r.trigger for r in replanner.history] == [
        "initial",
        "obstacle_sensed",
        "no_progress",
        "shape_changed",
        "goals_changed",
    ]
    assert all(r.latency_ms > 0 for r in replanner.history)


def test_incremental_replan_agrees_with_the_naive_path() -> None:
    k = knowledge([(3, 2), (-3, 3)], known=(Circle(1.5, 1, 0.5),))
    planner = NavigationPlanner(k, LIB, spacing=1.0)
    planner.plan(k)
    k = k.with_sensed(Circle(-1.5, 1.5, 0.5))
    ours = planner.plan(k)
    theirs, timings = naive_replan(planner)
    assert ours.result.solved and theirs.solved
    assert set(timings) == {"export_ms", "parse_ground_ms", "search_ms"}
    task = parse_and_ground(*planner.export())
    from domain.pyperplan_adapter import validate_plan

    assert validate_plan(task, ours.result.plan) == (
        True,
        "valid",
    )  # our plan is valid for pyperplan's grounding


def test_search_task_reports_unsolvable_not_none() -> None:
    k = knowledge([(3, 2)])
    planner = NavigationPlanner(k, LIB, spacing=1.0)
    planner.plan(k)
    from domain.pyperplan_adapter import Fact

    planner.task.goals = frozenset(
        {planner.task.fact("(visited g0)"), Fact("(unreachable)", 10**6)}
    )
    assert search_task(planner.task, "bfs", None).status == "unsolvable"

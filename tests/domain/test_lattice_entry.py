"""The goal-entry test is sound (when it says no motion ends on the goal, a search run to
exhaustion finds no plan), catches goals the resting-body test cannot, answers the same
compiled or not, and spares the planner its long search."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pyperplan.search import greedy_best_first_search

from domain import lattice_entry, lattice_planner
from domain.goal_order import LegGoal
from domain.grid_clearance import world_clearance
from domain.lattice import LatticeGrid, LatticeSettings, motion_table
from domain.lattice_distances import centroid_need, distance_map
from domain.lattice_entry import goal_entered
from domain.lattice_heuristic import LatticeHeuristic
from domain.lattice_planner import PARTIAL_AFTER, SEARCH_AGAIN, LatticePlanner
from domain.lattice_reach import Reachability
from domain.lattice_task import LatticeTask
from domain.worldmodel import WorldModel
from primitives.library import load_bundled
from sim.obstacles import Circle, rectangle
from sim.world import Bounds

LIB = load_bundled()
# A coarse lattice: small enough to search every state of a 2.4 m arena in a test.
COARSE = LatticeSettings(resolution=0.1, orientations=16, margin=0.02)
STRAIGHT = motion_table(LIB, "straight", (0.0, 0.0, 0.0), COARSE)
BOUNDS = Bounds(-1.2, 1.2, -1.2, 1.2)


def scene(seed: int) -> tuple[WorldModel, tuple[float, float]]:
    """Random discs, and a bar beside the goal (often too close for the body to get its
    head there, though the resting body fits)."""
    rng = np.random.default_rng(seed)
    goal = (float(rng.uniform(0.2, 0.7)), float(rng.uniform(0.2, 0.7)))
    angle = float(rng.uniform(0, math.pi))
    gap = float(rng.uniform(0.08, 0.3))
    bar = rectangle(
        goal[0] - gap * math.sin(angle), goal[1] - gap * math.cos(angle), 0.8, 0.08, angle
    )
    discs = []
    while len(discs) < 3:
        x, y = rng.uniform(-1.0, 1.0, 2)
        if math.hypot(x + 0.7, y + 0.7) > 0.6 and math.hypot(x - goal[0], y - goal[1]) > 0.4:
            discs.append(Circle(float(x), float(y), float(rng.uniform(0.08, 0.2))))
    return WorldModel(BOUNDS, [bar, *discs]), goal


def task_of(world: WorldModel, goal: tuple[float, float], k: int) -> LatticeTask:
    assert STRAIGHT is not None
    grid = LatticeGrid(BOUNDS, COARSE)
    start = (*grid.cell(-0.7, -0.7), k)
    task = LatticeTask(grid, STRAIGHT, world_clearance(world), start, goal, 0.06, 0.02, 0.0, 0)
    task.at_centres = task.clearance(grid.centres)
    return task


def exhausted(task: LatticeTask) -> bool:
    """Whether a search run to the end finds no plan."""
    assert STRAIGHT is not None
    dist = distance_map(task.grid, task.at_centres, task.goal, centroid_need(STRAIGHT), 0.5)
    h = LatticeHeuristic(task, dist, STRAIGHT.longest_step)
    with task.search_reached(greedy_best_first_search):
        return greedy_best_first_search(task, h) is None


@pytest.mark.parametrize("seed", range(8))
def test_no_motion_onto_the_goal_means_no_search_reaches_it(seed: int) -> None:
    world, goal = scene(seed)
    answers = []
    for k in (0, 5, 11):
        task = task_of(world, goal, k)
        entered = goal_entered(task)
        if not entered:
            assert exhausted(task_of(world, goal, k)), (seed, k)
        answers.append(entered)
    assert len(set(answers)) == 1  # the goal's side of the question: the same from any start


def test_it_catches_goals_the_resting_body_test_lets_through() -> None:
    """Over the seeded scenes, some goals are cut off by the bar for every motion of the body
    while the resting body's configurations connect with them; and some are entered."""
    assert STRAIGHT is not None
    caught = entered = 0
    for seed in range(8):
        world, goal = scene(seed)
        task = task_of(world, goal, 0)
        reach = Reachability(task.grid, STRAIGHT, task.at_centres, 0.02)
        if goal_entered(task):
            entered += 1
        elif reach.reaches(task.start_key, goal, task.reach):
            caught += 1
    assert caught >= 1 and entered >= 1


@pytest.mark.parametrize("seed", range(4))
def test_compiled_and_plain_answers_agree(seed: int, monkeypatch: pytest.MonkeyPatch) -> None:
    world, goal = scene(seed)
    for k in (0, 7):
        compiled = goal_entered(task_of(world, goal, k))
        with monkeypatch.context() as m:
            m.setattr(lattice_entry, "AVAILABLE", False)
            assert goal_entered(task_of(world, goal, k)) == compiled


def test_a_start_on_the_goal_is_entered() -> None:
    world = WorldModel(BOUNDS, [])
    task = task_of(world, (0.0, 0.0), 0)
    head = np.asarray(task.grid.centre(*task.start_key[:2])) + np.asarray(task.table.heads[0])
    on_goal = task_of(world, (float(head[0]), float(head[1])), 0)
    assert goal_entered(on_goal)


def test_the_planner_answers_unreachable_without_a_long_search(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Beside a goal no motion of the body brings the head onto (though the resting body's
    configurations connect with it), where the first short search gets no closer: the planner
    says so at once; without the entry test it would search ``SEARCH_AGAIN`` expansions more.
    A short search that got closer hands out its partial plan as before (sensing on the way
    may clear a guessed surface)."""
    assert STRAIGHT is not None
    world, goal = scene(2)
    budgets: list[float] = []
    search = LatticePlanner._search

    def counted(self: LatticePlanner, task: LatticeTask, distances: np.ndarray):  # type: ignore[no-untyped-def]
        budgets.append(task.budget)
        return search(self, task, distances)

    monkeypatch.setattr(LatticePlanner, "_search", counted)

    def plan(start: tuple[int, int, int]) -> tuple[str, str, bool]:
        budgets.clear()
        planner = LatticePlanner(BOUNDS, COARSE)
        pose = tuple(float(v) for v in planner.pose_of(STRAIGHT, start))
        legs = [LegGoal(0, goal[0], goal[1], 0.1)]
        out = planner.plan(STRAIGHT, world_clearance(world), world.version, pose, legs, True)
        return out.status, out.reason, out.partial

    beside = (12, 12, 4)  # 0.3 m from the goal, across the bar's end
    status, reason, _ = plan(beside)
    assert status == "unreachable" and "no collision-free motion" in reason
    assert budgets == [PARTIAL_AFTER]
    assert plan(task_of(world, goal, 0).start_key) == ("solved", "", True)  # farther: closer
    with monkeypatch.context() as m:
        m.setattr(lattice_planner, "goal_entered", lambda task: True)
        plan(beside)
        assert budgets == [PARTIAL_AFTER, SEARCH_AGAIN]

"""The roomy search's edges (review of issue #15): a cancel during it ends the plan
``cancelled``; the maps kept are those of the usual map, the body's joints and the margin they
were made from; a later leg's roomy map passes no cell its usual map cuts off; where no cell
with room leads to the goal the short search is not run a second time."""

from __future__ import annotations

import math
import threading

import numpy as np
import pytest

from domain.goal_order import LegGoal
from domain.lattice import LatticeGrid, motion_table
from domain.lattice_distances import centroid_need, distance_map, roomy_map
from domain.lattice_maps import PlannerMaps
from domain.lattice_planner import PARTIAL_AFTER, LatticePlanner
from domain.lattice_task import LatticeTask
from domain.pyperplan_adapter import PlanResult
from domain.worldmodel import WorldModel
from sim.obstacles import rectangle
from sim.robot import Array
from tests.domain.test_roomy_map import (
    AT_SLOT,
    BOUNDS,
    GOAL,
    LIB,
    SETTINGS,
    STRAIGHT,
    both_maps,
    clearance,
)


def test_a_cancel_during_the_roomy_search_ends_the_short_plan_cancelled(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    planner = LatticePlanner(BOUNDS, SETTINGS, time_limit=120.0)
    cancel = threading.Event()
    searched = planner._search
    calls: list[int] = []

    def search(task: LatticeTask, distances: Array) -> PlanResult:
        calls.append(int(task.budget))
        if len(calls) == 2:  # the roomy search: the mission is cancelled while it runs
            cancel.set()
        return searched(task, distances)

    monkeypatch.setattr(planner, "_search", search)
    assert STRAIGHT is not None
    plan = planner.plan(STRAIGHT, clearance, 0, AT_SLOT, (GOAL,), True, cancel, quick=True)
    assert len(calls) == 2  # the short search, then the roomy one
    assert plan.status == "cancelled", plan.reason


def test_the_roomy_map_kept_for_a_leg_is_made_from_the_usual_map_it_is_asked_with() -> None:
    # A later leg's roomy map starts where that leg starts; the usual map it adds to starts
    # where the plan starts (its cells near there passable). Two plans from different places
    # with the same world version and goal ask for the same leg's roomy map.
    assert STRAIGHT is not None
    grid = LatticeGrid(BOUNDS, SETTINGS)
    maps = PlannerMaps(grid)
    leg_start = (-1.0, 0.0)
    version = 0
    usual_a = maps.distances(STRAIGHT, clearance, version, GOAL, (AT_SLOT[0], AT_SLOT[1]))
    usual_b = maps.distances(STRAIGHT, clearance, version, GOAL, (-1.5, -0.5))
    assert not np.array_equal(usual_a, usual_b)  # the slot's mouth passable only in a's
    margin = SETTINGS.margin
    a, b = (AT_SLOT[0], AT_SLOT[1]), (-1.5, -0.5)
    first = maps.roomy(STRAIGHT, clearance, version, GOAL, leg_start, a, usual_a, margin)
    second = maps.roomy(STRAIGHT, clearance, version, GOAL, leg_start, b, usual_b, margin)
    at = maps.centre_clearance(clearance, version)
    free = float(np.linalg.norm(STRAIGHT.offset)) + GOAL.tolerance
    goal = (GOAL.x, GOAL.y)
    fresh = roomy_map(grid, at, goal, STRAIGHT, margin, free, leg_start, usual_b)
    assert not np.array_equal(first, fresh)
    assert np.array_equal(second, fresh)  # not the map made from the other plan's usual map


# A dead-end slot 0.3 m wide and 3 m deep, the goal at its end: the straight body fits it
# lengthwise, and no cell with room to turn leads there.
SLOT = [
    rectangle(1.5, 0.2, 3.2, 0.1, 0.0),
    rectangle(1.5, -0.2, 3.2, 0.1, 0.0),
    rectangle(3.15, 0.0, 0.1, 0.5, 0.0),
]
IN_SLOT = LegGoal(0, 2.8, 0.0, 0.1)
OUTSIDE = (-2.0, 0.0, 0.0)


def slot_clearance(points: np.ndarray) -> np.ndarray:
    out: np.ndarray = WorldModel(BOUNDS, SLOT).clearance_at(points)
    return out


def test_where_no_roomy_way_leads_to_the_goal_the_roomy_map_is_the_usual_one() -> None:
    start = (OUTSIDE[0], OUTSIDE[1])
    grid, usual, roomy = both_maps(slot_clearance, IN_SLOT, start)
    assert math.isfinite(usual[grid.cell(*start)])
    # (Before: the usual map plus a constant outside the goal's reach, a greedy search the
    # same as the usual map's, again.)
    assert np.array_equal(roomy, usual)


def test_a_short_search_that_found_nothing_is_not_run_again_when_no_roomy_way_leads_there(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    planner = LatticePlanner(BOUNDS, SETTINGS, time_limit=120.0)
    calls: list[int] = []

    def search(task: LatticeTask, distances: Array) -> PlanResult:
        calls.append(int(task.budget))  # a short search that found nothing closer (stand-in)
        return PlanResult("timeout", [], 1.0, int(task.budget) + 1, "search timeout")

    monkeypatch.setattr(planner, "_search", search)
    assert STRAIGHT is not None
    plan = planner.plan(STRAIGHT, slot_clearance, 0, OUTSIDE, (IN_SLOT,), True, quick=True)
    assert plan.status == "timeout"
    assert calls == [PARTIAL_AFTER]  # the short search once, not the same search twice


def test_a_later_legs_roomy_map_passes_no_cell_its_usual_map_cuts_off() -> None:
    # A later leg starts where the last one ended; its usual map was made with the cells near
    # the plan's start passable, the roomy one with those near the leg's start: by a wall
    # there, the roomy map let cells through that the usual map cuts off.
    assert STRAIGHT is not None
    grid = LatticeGrid(BOUNDS, SETTINGS)
    at = clearance(grid.centres)
    goal, free = (GOAL.x, GOAL.y), float(np.linalg.norm(STRAIGHT.offset)) + GOAL.tolerance
    usual = distance_map(grid, at, goal, centroid_need(STRAIGHT), free, (AT_SLOT[0], AT_SLOT[1]))
    leg_start = (0.85, -0.6)  # by the pocket's east wall
    roomy = roomy_map(grid, at, goal, STRAIGHT, SETTINGS.margin, free, leg_start, usual)
    assert math.isfinite(usual[grid.cell(*leg_start)])
    assert not np.any(np.isfinite(roomy) & ~np.isfinite(usual))


def test_the_maps_kept_for_a_shape_are_those_of_its_bodys_joints() -> None:
    # The navigation strategy makes one motion table per shape and joints held to 0.05 rad:
    # a straight body sensed bent (within the 0.15 rad its shape is named by) is another
    # table, with another centroid's need and head offset.
    bent = motion_table(LIB, "straight", (0.15, 0.15, 0.15), SETTINGS)
    assert STRAIGHT is not None and bent is not None
    assert centroid_need(bent) != centroid_need(STRAIGHT)
    grid = LatticeGrid(BOUNDS, SETTINGS)
    maps = PlannerMaps(grid)
    start = (AT_SLOT[0], AT_SLOT[1])
    maps.distances(STRAIGHT, clearance, 0, GOAL, start)
    kept = maps.distances(bent, clearance, 0, GOAL, start)
    at = maps.centre_clearance(clearance, 0)
    free = float(np.linalg.norm(bent.offset)) + GOAL.tolerance
    fresh = distance_map(grid, at, (GOAL.x, GOAL.y), centroid_need(bent), free, start)
    assert np.array_equal(kept, fresh)

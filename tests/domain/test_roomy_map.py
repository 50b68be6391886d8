"""The roomy map and the short search along it: where the centroid's map leads the search into a
bent slot the body cannot take, a second short search along the ways with room to turn finds
the whole way round; the roomy map never prunes a cell the usual map passes."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest

from domain.goal_order import LegGoal
from domain.lattice import LatticeGrid, LatticeSettings, motion_table
from domain.lattice_distances import centroid_need, distance_map, roomy_map, turn_room
from domain.lattice_plan import LatticePlan
from domain.lattice_planner import LatticePlanner
from domain.worldmodel import WorldModel
from primitives.library import load_bundled
from sim.obstacles import rectangle
from sim.world import Bounds

LIB = load_bundled()
SETTINGS = LatticeSettings()
BOUNDS = Bounds(-5.0, 5.0, -5.0, 5.0)
STRAIGHT = motion_table(LIB, "straight", (0.0, 0.0, 0.0), SETTINGS)
# A pocket 2.3 m wide, open to the west, whose closed east end has a bent 0.22 m slot (east,
# then north) out to the goal's side: a unit's disc fits it, the straight 0.96 m body cannot
# take its bend (examples/untuned4/dead-end-pocket-230-bent-slot-off-axis, its known walls).
POCKET = [
    rectangle(-0.2, -1.2, 2.6, 0.1, 0.0),
    rectangle(-0.2, 1.2, 2.6, 0.1, 0.0),
    rectangle(1.05, -0.475, 0.1, 1.45, 0.0),
    rectangle(1.05, 0.885, 0.1, 0.68, 0.0),
    rectangle(1.45, 0.25, 0.9, 0.1, 0.0),
    rectangle(1.29, 0.57, 0.58, 0.1, 0.0),
    rectangle(1.85, 0.9, 1.4, 0.1, math.pi / 2),
    rectangle(1.53, 1.06, 1.08, 0.1, math.pi / 2),
]
GOAL = LegGoal(0, 2.7, -0.2, 0.1)
AT_SLOT = (0.92, 0.66, -1.67)  # where the robot stands after its first (partial) plan
SENSED = 0.05  # walls it has seen are kept this much further (a navigation tier's clearance)


def clearance(points: np.ndarray) -> np.ndarray:
    """The pocket's clearance as a navigation tier keeps it (the seen walls grown)."""
    out: np.ndarray = WorldModel(BOUNDS, POCKET).clearance_at(points) - SENSED
    return out


def test_turn_room_is_the_sideways_sweep_of_one_orientation_step() -> None:
    assert STRAIGHT is not None
    farthest = max(float(np.max(np.hypot(p[:, 0], p[:, 1]))) for p in STRAIGHT.body_points)
    assert 0.45 < farthest < 0.5  # the body's end units, about half its 0.96 m from the centroid
    room = turn_room(STRAIGHT)
    assert room == pytest.approx(2 * farthest * math.sin(math.pi / SETTINGS.orientations))
    coarse = motion_table(LIB, "straight", (0.0, 0.0, 0.0), LatticeSettings(orientations=16))
    assert coarse is not None and turn_room(coarse) > 3.5 * room  # coarser turns need more


def both_maps(
    clear: Callable[[np.ndarray], np.ndarray], goal: LegGoal, start: tuple[float, float]
) -> tuple[LatticeGrid, np.ndarray, np.ndarray]:
    """The usual and the roomy distance map of the straight body to ``goal`` from ``start``."""
    assert STRAIGHT is not None
    grid = LatticeGrid(BOUNDS, SETTINGS)
    at = clear(grid.centres)
    to, free = (goal.x, goal.y), float(np.linalg.norm(STRAIGHT.offset)) + goal.tolerance
    usual = distance_map(grid, at, to, centroid_need(STRAIGHT), free, start)
    roomy = roomy_map(grid, at, to, STRAIGHT, SETTINGS.margin, free, start, usual)
    return grid, usual, roomy


def maps() -> tuple[LatticeGrid, np.ndarray, np.ndarray]:
    return both_maps(clearance, GOAL, (AT_SLOT[0], AT_SLOT[1]))


def test_the_roomy_way_goes_round_the_pocket_and_no_cell_is_pruned() -> None:
    grid, usual, roomy = maps()
    i, j = grid.cell(*AT_SLOT[:2])
    # Through the slot the goal is ~4.5 m away; round the pocket's open end over 8 m.
    assert usual[i, j] < 5.0
    assert roomy[i, j] > 8.0
    # Every cell the usual map passes, the roomy one passes too (a search along it stays
    # complete), and no other cell: what is cut off stays cut off.
    assert np.array_equal(np.isfinite(roomy), np.isfinite(usual))
    # The slot's cells cost more than any cell of the roomy way.
    slot = grid.cell(1.45, 0.41)
    assert math.isfinite(usual[slot]) and roomy[slot] >= usual[slot]
    roomy_way = roomy[np.isfinite(roomy) & (roomy < roomy[slot] - usual[slot])]
    assert roomy_way.size > 1000 and float(roomy_way.max()) < roomy[slot]


def plan_at_slot(planner: LatticePlanner) -> LatticePlan:
    """The planner's short plan from the slot's mouth (a time limit a first compile keeps)."""
    assert STRAIGHT is not None
    return planner.plan(STRAIGHT, clearance, 0, AT_SLOT, (GOAL,), True, quick=True)


def test_a_short_search_lost_in_the_slot_finds_the_way_round_along_the_roomy_map() -> None:
    plan = plan_at_slot(LatticePlanner(BOUNDS, SETTINGS, time_limit=120.0))
    assert plan.solved and not plan.partial, plan.reason
    assert plan.actions[-1].name == "visit" and plan.actions[-1].goal == 0
    xs = [a.target[0] for a in plan.actions]
    assert min(xs) < -1.5  # out of the pocket's open west end, not through the slot
    assert plan.expansions > 3000  # the first short search, then the roomy one


def test_without_the_roomy_search_the_short_search_finds_nothing_closer(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(LatticePlanner, "_roomy_search", lambda *a, **k: None)
    plan = plan_at_slot(LatticePlanner(BOUNDS, SETTINGS, time_limit=120.0))
    assert plan.status == "timeout" and "3,000 expansions" in plan.reason


class RoomySearched(Exception):
    """The roomy search was asked for."""


def test_an_a_star_planner_searches_without_the_roomy_map(monkeypatch: pytest.MonkeyPatch) -> None:
    """The roomy map's extra cost is a preference for greedy search; it would inflate A*'s."""

    def refused(*a: object, **k: object) -> None:
        raise RoomySearched

    monkeypatch.setattr(LatticePlanner, "_roomy_search", refused)
    with pytest.raises(RoomySearched):  # greedy search: lost in the slot, it asks
        plan_at_slot(LatticePlanner(BOUNDS, SETTINGS, time_limit=120.0))
    plan = plan_at_slot(LatticePlanner(BOUNDS, SETTINGS, search="astar", time_limit=120.0))
    assert plan.status in ("timeout", "solved")  # whatever A* finds, it found it without

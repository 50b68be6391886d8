"""A doubted goal from a start that touches something is searched as without doubt: the
reachability test starts from a free configuration next to the start, which may lie in a pocket
the first motion (keeping only the start's allowance) leaves for where the goal lies."""

from __future__ import annotations

import pytest

from domain import lattice_planner
from domain.goal_order import LegGoal
from domain.lattice import LatticeSettings, motion_table
from domain.lattice_planner import PARTIAL_AFTER, SEARCH_AGAIN, LatticePlanner
from domain.lattice_reach import Reachability
from domain.pyperplan_adapter import PlanResult
from domain.worldmodel import WorldModel
from primitives.library import load_bundled
from sim.obstacles import Circle
from sim.world import Bounds

SETTINGS = LatticeSettings()
BOUNDS = Bounds(-1.5, 1.5, -1.5, 1.5)
DISCS = [(0.133, -1.21, 0.167), (-0.327, -0.83, 0.123), (0.07, -0.147, 0.198)]
POSE = (-0.233, -0.293, 4.914)  # the body 6 cm into the disc at (0.07, -0.147)
GOAL = LegGoal(0, 1.1, -0.54, 0.1)


def test_a_touching_start_is_searched_though_doubted() -> None:
    table = motion_table(load_bundled(), "straight", (0.0, 0.0, 0.0), SETTINGS)
    assert table is not None
    world = WorldModel(BOUNDS, [Circle(*d) for d in DISCS])

    def plan(doubt: bool) -> list[str]:
        planner = LatticePlanner(BOUNDS, SETTINGS)
        got = planner.plan(
            table, world.clearance_at, world.version, POSE, [GOAL], True, doubt=doubt
        )
        assert got.status == "solved", got.reason
        return [a.primitive for a in got.actions]

    # What made the doubt wrong: the test, from the free configuration beside the start,
    # finds the goal apart; the first motion gets out anyway.
    planner = LatticePlanner(BOUNDS, SETTINGS)
    at = planner.maps.centre_clearance(world.clearance_at, world.version)
    test = Reachability(planner.grid, table, at, SETTINGS.margin)
    assert not test.reaches(planner.key_of(table, POSE), (GOAL.x, GOAL.y), 0.06, compiled=False)
    assert plan(doubt=True) == plan(doubt=False)


def test_a_touching_start_is_not_found_unreachable_after_a_long_search(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The same start when the short search runs out of expansions: the test after it asks
    from where the first motions lead too, so the goal (a plan exists) is not given up as
    unreachable; the search goes on (here it runs out again: a timeout, not a verdict)."""
    table = motion_table(load_bundled(), "straight", (0.0, 0.0, 0.0), SETTINGS)
    assert table is not None
    world = WorldModel(BOUNDS, [Circle(*d) for d in DISCS])
    planner = LatticePlanner(BOUNDS, SETTINGS)
    budgets: list[int] = []

    def long_search(task, distances):  # type: ignore[no-untyped-def]
        budgets.append(task.budget)
        return PlanResult("timeout", [], 1.0, task.budget, "search timeout")

    monkeypatch.setattr(planner, "_search", long_search)
    monkeypatch.setattr(lattice_planner, "goal_entered", lambda task: True)
    got = planner.plan(table, world.clearance_at, world.version, POSE, [GOAL], True)
    assert got.status == "timeout", got.reason
    assert budgets == [PARTIAL_AFTER, SEARCH_AGAIN]

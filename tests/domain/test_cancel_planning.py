"""A cancel ends planning: before the search, in the middle of it (compiled or pyperplan's);
the planner answers ``Failure("cancelled")`` and keeps no plan, the
strategy reports it and writes no problem; and a grounding of the whole lattice does not hold
the cancel up in the cycle collector."""

from __future__ import annotations

import gc
import threading
from collections.abc import Iterator

import pytest

from domain.goal_order import LegGoal
from domain.navigation import Failure, NavigationStrategy, Plan, Planner, PlanRequest
from domain.navigation.lattice.states import FREEZE_AFTER, no_cycle_collection
from domain.strategy import Situation
from domain.triggers import Initial, PathBlocked
from domain.world import WorldModel
from sim.obstacles import Circle
from sim.world import Bounds
from tests.domain.lattice_scenes import (
    LIB,
    SETTINGS,
    STRAIGHT,
    legs,
    scene,
)

BOUNDS = Bounds(-3.0, 3.0, -3.0, 3.0)


@pytest.fixture(autouse=True)
def unfreeze() -> Iterator[None]:
    yield
    gc.unfreeze()


class LateCancel:
    """A cancel flag set from its ``after``-th look on (a cancel arriving mid-search), counting
    the looks."""

    def __init__(self, after: int) -> None:
        self.after, self.looks = after, 0

    def is_set(self) -> bool:
        self.looks += 1
        return self.looks >= self.after


def long_request(cancel) -> tuple[Planner, PlanRequest]:
    """Across a cluttered arena, from a heading facing away: thousands of expansions."""
    bounds, obstacles = scene("cluttered", 6.0, 1)
    world = WorldModel(bounds, obstacles, SETTINGS.costmap)
    p = Planner(bounds, SETTINGS)
    x, y, psi = (float(v) for v in p.pose_of(STRAIGHT, (*p.grid.cell(-2.0, -2.0), 8)))
    request = PlanRequest((x, y, psi), STRAIGHT, legs([(2.2, 2.2)]), True, world, cancel)
    return p, request


def test_a_cancel_before_planning_ends_it_at_once() -> None:
    flag = threading.Event()
    flag.set()
    p, request = long_request(flag)
    out = p.plan(request)
    assert isinstance(out, Failure)
    assert (out.kind, out.reason, out.proof, out.goal) == (
        "cancelled",
        "planning cancelled",
        None,
        None,
    )


def test_without_a_cancel_the_same_request_is_planned() -> None:
    p, request = long_request(LateCancel(after=10**9))
    out = p.plan(request)
    assert isinstance(out, Plan) and out.expansions > 3 * 256  # several chunks of the kernel
    assert request.cancel is not None and request.cancel.looks > 3  # type: ignore[attr-defined]


@pytest.mark.parametrize("search", ["cost", "gbf"])
def test_a_cancel_arriving_mid_search_ends_it(search: str) -> None:
    """The flag is looked at before each goal's map and between chunks of the search (or every
    expansion of pyperplan's): set on the third look, the search is under way."""
    cancel = LateCancel(after=3)
    _, request = long_request(cancel)
    bounds = request.world.bounds
    out = Planner(bounds, SETTINGS, search=search).plan(request)
    assert isinstance(out, Failure) and out.kind == "cancelled"
    assert cancel.looks == 3  # it stopped at the look that saw the cancel


def situation(world: WorldModel) -> Situation:
    goals = tuple(LegGoal(i, 2.0, -2.0 + i, 0.1) for i in range(3))
    return Situation(0.0, (-2.0, 0.0, 0.0), (0.0, 0.0, 0.0), "straight", goals, False, world)


def test_a_cancelled_replan_reports_it_and_writes_no_problem() -> None:
    world = WorldModel(BOUNDS, [Circle(0.0, 0.0, 0.5)], SETTINGS.costmap)
    strategy = NavigationStrategy(LIB, Planner(BOUNDS, SETTINGS))
    out = strategy.replan(situation(world), Initial(), LateCancel(after=4))
    assert not out.ok and out.failure == "cancelled" and out.record.status == "cancelled"
    assert out.record.trigger == "initial" and out.plan == []
    assert out.problem_pddl == ""  # nothing written for a cancelled search's lattice
    assert strategy.plan is None
    assert strategy.table is not None and strategy.table.shape == "straight"
    # The next replan, not cancelled, plans as usual.
    again = strategy.replan(situation(world), PathBlocked("(move s1 s2 p)", (0.0, 0.0)))
    assert again.ok and again.plan and strategy.plan is not None


def test_a_long_pause_freezes_what_it_made_and_a_short_one_does_not() -> None:
    before = gc.get_freeze_count()
    with no_cycle_collection(freeze_after=True):
        few = [[i] for i in range(1_000)]
    assert gc.get_freeze_count() == before and gc.isenabled()
    with no_cycle_collection(freeze_after=True):
        many = [[i] for i in range(FREEZE_AFTER + 10_000)]  # lists: tracked by the collector
    assert gc.get_freeze_count() >= before + len(many) and gc.isenabled()
    del few, many

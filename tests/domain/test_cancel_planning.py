"""A cancel ends planning at once: no other shape is tried, no problem written for it, and a
grounding of the whole lattice does not hold the cancel up in the cycle collector."""

from __future__ import annotations

import gc
import threading
from collections.abc import Iterator

import pytest

from domain.goal_order import LegGoal
from domain.lattice import LatticeSettings
from domain.lattice_planner import LatticePlanner
from domain.lattice_states import FREEZE_AFTER, no_cycle_collection
from domain.navigation_strategy import NavigationStrategy
from domain.strategy import Situation
from domain.triggers import Initial
from domain.worldmodel import WorldModel
from primitives.library import load_bundled
from sim.obstacles import Circle
from sim.world import Bounds

BOUNDS = Bounds(-3.0, 3.0, -3.0, 3.0)


@pytest.fixture(autouse=True)
def unfreeze() -> Iterator[None]:
    yield
    gc.unfreeze()


def situation(world: WorldModel) -> Situation:
    goals = tuple(LegGoal(i, 2.0, -2.0 + i, 0.1) for i in range(3))
    return Situation(0.0, (-2.0, 0.0, 0.0), (0.0, 0.0, 0.0), "straight", goals, False, world)


class LateCancel:
    """A cancel flag set from its ``after``-th look on (a cancel arriving mid-search)."""

    def __init__(self, after: int) -> None:
        self.after, self.looks = after, 0

    def is_set(self) -> bool:
        self.looks += 1
        return self.looks >= self.after


def test_a_cancelled_replan_ends_at_once_with_no_problem_to_write() -> None:
    world = WorldModel(BOUNDS, [Circle(0.0, 0.0, 0.5)])
    strategy = NavigationStrategy(load_bundled(), LatticePlanner(BOUNDS, LatticeSettings()))
    cancel = LateCancel(after=4)  # the distance maps look first, then the search
    out = strategy.replan(situation(world), Initial(), cancel)
    assert not out.ok and out.record.status == "cancelled"
    assert strategy.plan is not None and strategy.plan.legs  # it had searched a while
    assert out.problem_pddl == ""  # nothing written for a cancelled search's lattice
    assert strategy.table is not None and strategy.table.shape == "straight"  # no reshape


def test_reshaping_tries_no_shape_once_cancelled() -> None:
    world = WorldModel(BOUNDS, [Circle(0.0, 0.0, 0.5)])
    planner = LatticePlanner(BOUNDS, LatticeSettings())
    strategy = NavigationStrategy(load_bundled(), planner)
    table = strategy.table_for("straight", (0.0, 0.0, 0.0))
    assert table is not None
    cancel = threading.Event()
    cancel.set()
    s = situation(world)
    assert strategy._reshaped(table, s, s.pose, cancel) is None
    tier_free = planner.cut_off(table, world.clearance_at, 0, s.pose, s.goals, cancel)
    assert tier_free  # no distance map is made for a cancelled mission: taken as cut off


def test_a_long_pause_freezes_what_it_made_and_a_short_one_does_not() -> None:
    before = gc.get_freeze_count()
    with no_cycle_collection(freeze_after=True):
        few = [[i] for i in range(1_000)]
    assert gc.get_freeze_count() == before and gc.isenabled()
    with no_cycle_collection(freeze_after=True):
        many = [[i] for i in range(FREEZE_AFTER + 10_000)]  # lists: tracked by the collector
    assert gc.get_freeze_count() >= before + len(many) and gc.isenabled()
    del few, many

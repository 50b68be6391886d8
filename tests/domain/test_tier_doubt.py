"""The navigation strategy remembers which clearance tiers found the goal unreachable, and asks
the planner to doubt them (reachability before any search) at the next replan."""

from __future__ import annotations

from typing import Any

import pytest

from domain import tier_walk
from domain.clearance_tiers import Tier
from domain.goal_order import LegGoal
from domain.lattice import LatticeSettings
from domain.lattice_plan import LatticePlan
from domain.lattice_planner import LatticePlanner
from domain.navigation_strategy import NavigationStrategy
from domain.strategy import Situation
from domain.triggers import Initial
from domain.worldmodel import WorldModel
from primitives.library import load_bundled
from sim.world import Bounds

BOUNDS = Bounds(-3.0, 3.0, -3.0, 3.0)
TIERS = [Tier("all"), Tier("off-goals"), Tier("none"), Tier("none", 0.02, 0.01)]


def test_tiers_unreachable_last_time_are_doubted_and_the_last_never(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    planner = LatticePlanner(BOUNDS, LatticeSettings())
    strategy = NavigationStrategy(load_bundled(), planner)
    monkeypatch.setattr(tier_walk, "tiers", lambda suspected: TIERS)
    asked: list[tuple[str, bool]] = []
    unreachable = {"all", "off-goals", "none"}  # only the last tier finds a plan at first

    def plan(*args: Any, family: Tier, doubt: bool = False, **kw: Any) -> LatticePlan:
        asked.append((f"{family.suspected}/{family.grow}", doubt))
        if family.suspected in unreachable and family != TIERS[-1]:
            return LatticePlan("unreachable", "unreachable: stand-in")
        return LatticePlan("unsolvable", "unreachable: stand-in")  # every tier is tried

    monkeypatch.setattr(planner, "plan", plan)
    monkeypatch.setattr(strategy, "_reshaped", lambda *a: None)  # this shape's tiers only
    world = WorldModel(BOUNDS, [])
    goals = (LegGoal(0, 2.0, 2.0, 0.1),)
    s = Situation(0.0, (-2.0, 0.0, 0.0), (0.0, 0.0, 0.0), "straight", goals, False, world)
    strategy.replan(s, Initial())
    assert [d for _, d in asked] == [False] * 4  # nothing known yet
    asked.clear()
    strategy.replan(s, Initial())
    # Unreachable at the last replan: doubted; the last tier's plan is the answer: never.
    assert asked[:4] == [("all/0.1", True), ("off-goals/0.1", True), ("none/0.1", True),
                         ("none/0.02", False)]  # fmt: skip
    unreachable.discard("all")  # something cleared: the first tier finds a plan
    asked.clear()
    strategy.replan(s, Initial())
    asked.clear()
    strategy.replan(s, Initial())
    assert asked[0] == ("all/0.1", False)  # no longer doubted once it found one

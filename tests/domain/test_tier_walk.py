"""The tier walk: a tier whose short search finds nothing closer asks the looser tiers' short
searches for a whole plan before its own long search, and long searches wait for a turn to
sense (``NavigationStrategy._plan``)."""

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
Answer = dict[tuple[str, bool], LatticePlan]  # (tier, quick) -> its plan


def name(tier: Tier) -> str:
    return f"{tier.suspected}/{tier.grow}"


def walk(
    monkeypatch: pytest.MonkeyPatch, answers: Answer
) -> tuple[NavigationStrategy, list[tuple[str, bool]]]:
    """A strategy whose planner answers from ``answers`` (default: a timeout) and records
    every (tier, quick) it is asked."""
    planner = LatticePlanner(BOUNDS, LatticeSettings())
    strategy = NavigationStrategy(load_bundled(), planner)
    monkeypatch.setattr(tier_walk, "tiers", lambda suspected: TIERS)
    asked: list[tuple[str, bool]] = []

    def plan(*args: Any, family: Tier, quick: bool = False, **kw: Any) -> LatticePlan:
        asked.append((name(family), quick))
        return answers.get((name(family), quick), LatticePlan("timeout", "stand-in"))

    monkeypatch.setattr(planner, "plan", plan)
    monkeypatch.setattr(strategy, "_reshaped", lambda *a: None)  # this shape's tiers only
    return strategy, asked


def situation() -> Situation:
    goals = (LegGoal(0, 2.0, 2.0, 0.1),)
    world = WorldModel(BOUNDS, [])
    return Situation(0.0, (-2.0, 0.0, 0.0), (0.0, 0.0, 0.0), "straight", goals, False, world)


def test_a_looser_tiers_whole_plan_comes_before_the_strict_tiers_long_search(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    whole = LatticePlan("solved", "whole")
    strategy, asked = walk(monkeypatch, {("none/0.1", True): whole})
    monkeypatch.setattr(tier_walk, "tier_clearance", lambda w, tier, goals=(): name(tier))
    out = strategy.replan(situation(), Initial())
    assert out.ok and strategy.plan is whole
    # "all" found nothing near: "off-goals" (nothing either), then "none" has a whole plan.
    assert asked == [("all/0.1", True), ("off-goals/0.1", True), ("none/0.1", True)]
    # The plan is guarded against the clearance of the tier it keeps, not the first one's.
    assert strategy.clearance == "none/0.1"


def test_a_partial_looser_plan_does_not_give_up_the_stricter_tier(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    partial = LatticePlan("solved", "partial", partial=True)
    strict = LatticePlan("solved", "long search")
    answers = {("off-goals/0.1", True): partial, ("all/0.1", False): strict}
    strategy, asked = walk(monkeypatch, answers)
    strategy.recoveries = 1  # after a turn to sense: long searches are allowed
    strategy.replan(situation(), Initial())
    assert strategy.plan is strict
    assert asked == [
        ("all/0.1", True),
        *[(name(t), True) for t in TIERS[1:]],  # no looser whole plan
        ("all/0.1", False),  # so the strict tier searches long
    ]


def test_when_no_tier_finds_one_near_the_robot_turns_to_sense_before_searching_long(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    strategy, asked = walk(monkeypatch, {})
    strategy.replan(situation(), Initial())
    assert asked == [(name(t), True) for t in TIERS]  # short searches only
    assert strategy.plan is not None and strategy.plan.reason == "recovery"  # a turn
    assert strategy.backoff and all(e.turn != 0.0 for e in strategy.backoff)
    asked.clear()
    strategy.replan(situation(), Initial())  # after the turn: the strict tier searches long
    assert asked == [("all/0.1", True), *((name(t), True) for t in TIERS[1:]), ("all/0.1", False)]
    assert strategy.plan is not None and strategy.plan.reason == "recovery"  # and turns again
    assert strategy.recoveries == 2


def test_without_a_free_turn_the_long_search_comes_at_once(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    strategy, asked = walk(monkeypatch, {})
    monkeypatch.setattr(strategy, "_spin", lambda *a: [])
    strategy.replan(situation(), Initial())
    assert ("all/0.1", False) in asked
    assert strategy.plan is not None and strategy.plan.status == "timeout"


def test_the_last_tier_searches_long_at_once(monkeypatch: pytest.MonkeyPatch) -> None:
    unreachable = LatticePlan("unreachable", "unreachable: stand-in")
    answers = {(name(t), q): unreachable for t in TIERS[:-1] for q in (True, False)}
    strategy, asked = walk(monkeypatch, answers)
    strategy.recoveries = 1
    strategy.replan(situation(), Initial())
    assert asked == [*((name(t), True) for t in TIERS[:-1]), ("none/0.02", False)]

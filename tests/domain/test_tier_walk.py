"""The tier walk: a tier whose short search finds nothing closer asks the looser tiers' short
searches for a whole plan before its own long search, and long searches wait for a turn to
sense (``NavigationStrategy._plan``)."""

from __future__ import annotations

import threading
from typing import Any

import numpy as np
import pytest

from domain import tier_walk
from domain.clearance_tiers import Tier
from domain.goal_order import LegGoal
from domain.lattice import LatticeSettings, compose
from domain.lattice_plan import LatticePlan
from domain.lattice_planner import LatticePlanner
from domain.lattice_task import LatticeTask
from domain.navigation_strategy import NavigationStrategy
from domain.strategy import Situation
from domain.triggers import Contact, Initial
from domain.worldmodel import WorldModel
from primitives.library import Primitive, load_bundled
from sim.obstacles import Circle
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
    # The short searches and the looser tiers' probes are not asked twice: the long search
    # begins with the strict tier's short search itself.
    assert asked == [*((name(t), True) for t in TIERS), ("all/0.1", False)]
    assert strategy.plan is not None and strategy.plan.status == "timeout"


def test_the_last_tier_searches_long_at_once(monkeypatch: pytest.MonkeyPatch) -> None:
    unreachable = LatticePlan("unreachable", "unreachable: stand-in")
    answers = {(name(t), q): unreachable for t in TIERS[:-1] for q in (True, False)}
    strategy, asked = walk(monkeypatch, answers)
    strategy.recoveries = 1
    strategy.replan(situation(), Initial())
    assert asked == [*((name(t), True) for t in TIERS[:-1]), ("none/0.02", False)]


def free_turns(strategy: NavigationStrategy, pose: tuple[float, float, float]) -> set[str]:
    """The library turns of the straight body that keep the margin from ``pose``'s state."""
    table = strategy.table_for("straight", (0.0, 0.0, 0.0))
    assert table is not None and strategy.clearance is not None
    planner, margin = strategy.planner, strategy.settings.margin
    key = planner.key_of(table, pose)
    task = LatticeTask(
        planner.grid, table, strategy.clearance, key, (0.0, 0.0), 0.0, margin, margin
    )
    moves = {table.motions[m].primitive for _, m in task.valid_motions(key)}
    return {e.id for e in strategy.library.lattice("straight") if e.turn != 0.0 and e.id in moves}


def test_a_recovery_turn_after_a_contact_is_free_where_it_runs(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    strategy, _ = walk(monkeypatch, {})  # no tier finds a way near: the robot turns
    world = WorldModel(BOUNDS, [Circle(0.8, 0.1, 0.1)])
    goals = situation().goals
    s = Situation(0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), "straight", goals, False, world)
    strategy.replan(s, Contact(0, "left", (0.0, 0.05)))
    *back, turn = strategy.backoff
    assert back and all(e.turn == 0.0 for e in back) and turn.turn != 0.0
    # The turn runs after backing off from the touched side, so it must be free there (at the
    # touching pose the largest turn is free, and from where it runs it sweeps the disc).
    here = np.asarray(s.pose, dtype=float)
    for entry in back:
        here = compose(here, np.asarray(entry.end_pose))
    assert turn.id in free_turns(strategy, (float(here[0]), float(here[1]), float(here[2])))


def test_a_recovery_turn_after_shapes_that_found_no_plan_keeps_the_walks_clearance(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    strategy, _ = walk(monkeypatch, {})
    monkeypatch.delattr(strategy, "_reshaped")  # the real reshape this time
    monkeypatch.setattr(tier_walk, "tier_clearance", lambda w, tier, goals=(): name(tier))
    monkeypatch.setattr(strategy.tiers, "may_reach", lambda *a: True)
    monkeypatch.setattr("domain.navigation_strategy.reshape_clear", lambda *a: True)
    planner_plan = strategy.planner.plan

    def plan(table: Any, *args: Any, **kw: Any) -> LatticePlan:
        if table.shape != "straight":  # every other shape: no tier reaches the goal
            return LatticePlan("unreachable", "unreachable: stand-in")
        return planner_plan(table, *args, **kw)

    monkeypatch.setattr(strategy.planner, "plan", plan)
    checked: list[Any] = []

    def spin(table: Any, pose: Any) -> list[Primitive]:
        checked.append(strategy.clearance)
        return [strategy.library.get("lat-straight-rp45p0")]

    monkeypatch.setattr(strategy, "_spin", spin)
    strategy.recoveries = 1  # long searches: a timeout then tries the other shapes
    strategy.replan(situation(), Initial())
    assert strategy.plan is not None and strategy.plan.reason == "recovery"
    # The turn is checked against the strict tier the walk ended in, not against the loosest
    # tier of the last other shape tried (which passes contacts at 0.02 m).
    assert checked == ["all/0.1"]


def test_a_cancel_between_the_short_search_and_the_probes_hands_out_no_turn(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    strategy, asked = walk(monkeypatch, {})  # the strict tier's short search found none near
    cancel = threading.Event()
    cancel.set()  # and the mission was cancelled as it ended
    out = strategy.replan(situation(), Initial(), cancel)
    assert asked == [("all/0.1", True)]  # no looser tier is asked
    assert not out.ok and out.record.status == "cancelled" and out.reason == "planning cancelled"
    assert strategy.backoff == []  # no turn to sense is handed out


def test_after_a_turn_nothing_near_searches_long_until_a_whole_plan(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    answers: Answer = {}
    strategy, asked = walk(monkeypatch, answers)
    strategy.replan(situation(), Initial())  # nothing near: a turn first
    assert strategy.recoveries == 1 and ("all/0.1", False) not in asked
    answers[("all/0.1", True)] = LatticePlan("solved", "partial", partial=True)
    strategy.replan(situation(), Initial())  # a partial plan runs: the count stays
    assert strategy.plan is answers[("all/0.1", True)] and strategy.recoveries == 1
    del answers[("all/0.1", True)]
    asked.clear()
    strategy.replan(situation(), Initial())  # nothing near again: long at once (README)
    assert ("all/0.1", False) in asked and strategy.recoveries == 2
    answers[("all/0.1", True)] = LatticePlan("solved", "whole")
    strategy.replan(situation(), Initial())  # a whole plan starts the count again
    del answers[("all/0.1", True)]
    asked.clear()
    strategy.replan(situation(), Initial())
    assert ("all/0.1", False) not in asked and strategy.recoveries == 1

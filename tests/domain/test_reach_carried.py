"""Reachability carried over from the last world: a ``False`` only where the exact labelling
says so, the same answers as made afresh, and a planner that asks it first where a goal was
unreachable at the last replan ends in the same plan without a search."""

from __future__ import annotations

import numpy as np
import pytest

from domain import reach_components, reach_memory
from domain.goal_order import LegGoal
from domain.lattice import LatticeGrid, LatticeSettings, motion_table
from domain.lattice_planner import PARTIAL_AFTER, LatticePlanner
from domain.lattice_reach import Reachability
from domain.pyperplan_adapter import PlanResult
from domain.reach_components import carried_over, exact_components
from domain.worldmodel import WorldModel
from primitives.library import load_bundled
from sim.obstacles import Circle
from sim.world import Bounds
from tests.domain.disc_scenes import clearance

SETTINGS = LatticeSettings()
TABLE = motion_table(load_bundled(), "straight", (0.0, 0.0, 0.0), SETTINGS)
BOUNDS = Bounds(-1.5, 1.5, -1.5, 1.5)
PEN = (0.9, 0.9)


def pen(gap: int = 0, n: int = 40) -> list[tuple[float, float, float]]:
    """Small discs on a circle of 0.5 m round ``PEN``, less ``gap`` of them on the side of
    the arena's centre (a way in)."""
    a = np.linspace(0, 2 * np.pi, n, endpoint=False)
    a = np.r_[a[: n // 2], a[n // 2 + gap :]]
    return [(PEN[0] + 0.5 * np.cos(t), PEN[1] + 0.5 * np.sin(t), 0.06) for t in a]


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("renumbered", [False, True])
def test_carried_components_never_part_what_connects(
    seed: int, renumbered: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Free configurations changed inside a box: every exact component of the new ones lies
    within one carried-over component (apart there means apart); also when the earlier
    nodes are first numbered afresh (after many carries)."""
    if renumbered:
        monkeypatch.setattr(reach_components, "RENUMBER_AFTER", 0)
    rng = np.random.default_rng(seed)
    K, nx, ny = 4, 24, 24
    before = rng.uniform(size=(K, nx, ny)) < 0.3
    old = exact_components(before)
    after = before.copy()
    i0, j0 = rng.integers(0, 16, 2)
    box = (slice(int(i0), int(i0) + 6), slice(int(j0), int(j0) + 7))
    after[:, box[0], box[1]] = rng.uniform(size=(K, 6, 7)) < 0.3  # some cut, some joined
    carried = carried_over(old, after, box)
    exact = exact_components(after)
    assert not carried.exact
    mapped = carried.component[carried.labels][after]
    truth = exact.component[exact.labels][after]
    for component in np.unique(truth):
        assert np.unique(mapped[truth == component]).size == 1, component
    # And it is not merely everything in one: something stays apart.
    assert np.unique(mapped).size > 1


def test_a_chain_of_worlds_answers_as_each_made_afresh() -> None:
    """A pen closed, opened, closed again (its components cut apart since: carried over
    they stay joined, so the exact labelling answers), then a disc sensed elsewhere (a
    ``False`` the carried-over components give alone)."""
    assert TABLE is not None
    grid = LatticeGrid(BOUNDS, SETTINGS)
    rng = np.random.default_rng(7)
    elsewhere = [(0.9, -0.9, 0.15)]
    worlds = [pen(), pen(gap=8), pen(), [*pen(), *elsewhere], [*pen(), (0.9, -0.9, 0.2)]]
    chained: Reachability | None = None
    answers, carried_false = [], 0
    for discs in worlds:
        at = clearance(grid, discs)
        chained = Reachability(grid, TABLE, at, margin=0.03, previous=chained)
        fresh = Reachability(grid, TABLE, at, margin=0.03)
        outside = (18, 18, 0)  # (-0.6, -0.6), heading along x
        for goal in [PEN, (-1.1, 1.1), tuple(rng.uniform(-1.3, 1.3, 2))]:
            got = chained.reaches(outside, goal, 0.08, compiled=False)  # (no flood)
            assert got == fresh.reaches(outside, goal, 0.08, compiled=False), (discs, goal)
            answers.append(got)
            labels = chained._labels
            carried_false += bool(not got and labels is not None and not labels.exact)
    assert answers[0] is False and answers[3] is True  # closed, then open
    assert carried_false > 0  # carried-over components gave a ``False`` of their own


def test_a_doubted_goal_is_found_unreachable_before_any_search(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """``doubt``: the reachability test first; when it says no, the plan is the same
    ``unreachable`` a search and the test after it end in, without the search. A goal it
    finds reachable is planned as without ``doubt``."""
    assert TABLE is not None
    world = WorldModel(BOUNDS, [Circle(0.0, 0.0, 0.3)])
    legs = [LegGoal(0, 1.1, 1.1, 0.1)]
    searched: list[int] = []

    def plan(doubt: bool, apart: bool, pose=(-1.1, -1.1, 0.0)):  # type: ignore[no-untyped-def]
        p = LatticePlanner(BOUNDS, SETTINGS)
        search = p._search

        def counted(task, distances):  # type: ignore[no-untyped-def]
            searched.append(task.budget)
            if apart:  # the search cannot get there (nor any: see the test below)
                return PlanResult("timeout", [], 1.0, task.budget, "search timeout")
            return search(task, distances)

        with monkeypatch.context() as m:
            m.setattr(p, "_search", counted)
            if apart:  # as a pen sensed round the goal would
                m.setattr(Reachability, "reaches", lambda *a, **k: False)
                m.setattr(Reachability, "reaches_after", lambda *a, **k: False)
            searched.clear()
            return p.plan(TABLE, world.clearance_at, world.version, pose, legs, True, doubt=doubt)

    doubted = plan(True, apart=True)
    assert doubted.status == "unreachable" and searched == []  # no search when doubted
    searched_out = plan(False, apart=True)
    assert searched_out.status == "unreachable" and searched == [PARTIAL_AFTER]
    assert doubted.reason == searched_out.reason
    # Within one motion's reach (a plan of one motion keeps only the start's allowance, which
    # the test does not grant): searched first all the same.
    near = plan(True, apart=True, pose=(0.6, 1.1, 0.0))
    assert near.status == "unreachable" and searched == [PARTIAL_AFTER]
    first, again = plan(False, apart=False), plan(True, apart=False)
    assert first.solved and again.solved
    assert [a.name for a in again.actions] == [a.name for a in first.actions]


def test_reachability_answers_are_kept_within_a_byte_budget(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The latest answers per clearance family are kept (the next world's carry over from
    them) until their components pass ``REACH_BYTES``; the least recently used go first."""
    assert TABLE is not None
    world = WorldModel(BOUNDS, [Circle(*d) for d in pen()])
    p = LatticePlanner(BOUNDS, SETTINGS)
    asked = {}
    for family in ("a", "b", "c"):
        asked[family] = p.reachability(TABLE, world.clearance_at, (0, family), family)
        assert not asked[family].reaches((18, 18, 0), PEN, 0.08, compiled=False)  # labelled
    assert len(p.reach_memory) == 3 and asked["a"].held_bytes() > 0
    one = asked["a"].held_bytes()
    monkeypatch.setattr(reach_memory, "REACH_BYTES", int(2.5 * one))
    newest = p.reachability(TABLE, world.clearance_at, (0, "d"), "d")
    newest.reaches((18, 18, 0), PEN, 0.08, compiled=False)
    p.reachability(TABLE, world.clearance_at, (0, "b"), "b")  # used again: kept
    assert p.reachability(TABLE, world.clearance_at, (0, "b"), "b") is asked["b"]
    kept = set(p.reach_memory.families())
    assert "a" not in kept and "b" in kept and "d" in kept
    assert p.reach_memory.held_bytes() <= int(2.5 * one)


def test_changes_all_over_the_arena_are_labelled_afresh() -> None:
    """A box of changes spanning most of the grid is not carried over (labelling afresh costs
    less); the answer is the same."""
    assert TABLE is not None
    grid = LatticeGrid(BOUNDS, SETTINGS)
    before = Reachability(grid, TABLE, clearance(grid, pen()), margin=0.03)
    assert not before.reaches((18, 18, 0), PEN, 0.08, compiled=False)
    corners = [*pen(), (-1.3, -1.3, 0.1), (1.3, 1.3, 0.05), (1.3, -1.3, 0.1)]
    after = Reachability(grid, TABLE, clearance(grid, corners), margin=0.03, previous=before)
    assert not after.reaches((18, 18, 0), PEN, 0.08, compiled=False)
    assert after._labels is not None and after._labels.exact

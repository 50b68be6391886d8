"""The compiled lattice search finds what pyperplan's greedy best-first search finds: the same
operators, expansions, best node and expanded lattice, on seeded random worlds (open,
cluttered, narrow, unsolvable, stopped by the budget), with the planner's and the repair's
heuristics, through the motion cache; and the clearance's compiled form reads the callable's
values."""

from __future__ import annotations

import math
import threading
from typing import Any

import numpy as np
import pytest
from pyperplan.search import greedy_best_first_search

from domain import lattice_search, lattice_search_kernel
from domain.clearance_tiers import Tier, tier_clearance, tiers
from domain.goal_order import LegGoal
from domain.grid_clearance import GridClearance, world_clearance
from domain.lattice import LatticeGrid, LatticeSettings, motion_table
from domain.lattice_cache import MotionCache
from domain.lattice_distances import centroid_need, distance_map
from domain.lattice_heuristic import LatticeHeuristic
from domain.lattice_planner import LatticePlanner
from domain.lattice_task import LatticeTask
from domain.pyperplan_adapter import SearchStopped, validate_plan
from domain.worldmodel import WorldModel
from primitives.library import load_bundled
from sim.obstacles import Circle, rectangle
from sim.world import Bounds

LIB = load_bundled()
SETTINGS = LatticeSettings()
STRAIGHT = motion_table(LIB, "straight", (0.0, 0.0, 0.0), SETTINGS)
ARC = motion_table(LIB, "arc", (0.0, 0.0, 0.0), SETTINGS)
pytestmark = pytest.mark.skipif(not lattice_search.AVAILABLE, reason="compiled kernels off")


def world_of(kind: str, side: float, seed: int) -> WorldModel:
    """A square arena of ``side`` metres: ``open``, ``cluttered`` (random discs), ``narrow``
    (a wall with a gap the body fits through lengthwise) or ``enclosed`` (the goal walled in)."""
    h = side / 2
    bounds = Bounds(-h, h, -h, h)
    rng = np.random.default_rng(seed)
    obstacles: list[Any] = []
    if kind == "cluttered":
        while len(obstacles) < int(side * side / 3):
            x, y = rng.uniform(-h + 0.4, h - 0.4, 2)
            if (
                math.hypot(x + h - 1.0, y + h - 1.0) > 0.7
                and math.hypot(x - h + 0.8, y - h + 0.8) > 0.6
            ):
                obstacles.append(Circle(float(x), float(y), float(rng.uniform(0.1, 0.3))))
    elif kind == "narrow":  # a wall across the arena with a 0.5 m gap
        gap = float(rng.uniform(-0.5, 0.5))
        low, high = gap - 0.25, gap + 0.25
        obstacles += [
            rectangle(0.0, (-h + low) / 2, 0.1, low + h),
            rectangle(0.0, (high + h) / 2, 0.1, h - high),
        ]
    elif kind == "enclosed":
        gx = gy = h - 0.8
        obstacles += [
            Circle(gx + 0.45 * math.cos(a), gy + 0.45 * math.sin(a), 0.12)
            for a in np.linspace(0, 2 * math.pi, 13)[:-1]
        ]
    return WorldModel(bounds, obstacles)


def leg_task(
    world: WorldModel, table: Any, clearance: Any, k: int, cache: MotionCache | None = None
) -> tuple[LatticeTask, LatticeHeuristic]:
    """A leg from near one corner (heading bin ``k``) to near the other, and its heuristic."""
    h = world.bounds.xmax
    grid = LatticeGrid(world.bounds, SETTINGS)
    start = (*grid.cell(-h + 1.0, -h + 1.0), k)
    goal = (h - 0.8, h - 0.8)
    task = LatticeTask(grid, table, clearance, start, goal, 0.06, SETTINGS.margin, 0.0, 0)
    task.at_centres = clearance(grid.centres)
    if cache is not None:
        task.cache = cache
    dist = distance_map(
        grid,
        task.at_centres,
        goal,
        centroid_need(table),
        0.06 + float(np.linalg.norm(table.offset)),
    )
    return task, LatticeHeuristic(task, dist, table.longest_step)


def outcome(task: LatticeTask, heuristic: LatticeHeuristic, compiled: bool) -> dict[str, Any]:
    """What a search shows: its plan (or how it stopped), expansions, best node, lattice."""
    try:
        if compiled:
            assert lattice_search.applies(task, heuristic)
            plan = lattice_search.search(task, heuristic)
        else:
            with task.search_reached(greedy_best_first_search):
                plan = greedy_best_first_search(task, heuristic)
        status = "solved" if plan is not None else "unsolvable"
        names = [op.name for op in plan] if plan is not None else []
    except SearchStopped as stop:
        status, names = stop.status, []
    best = heuristic.best
    assert best is not None
    return {
        "status": status,
        "plan": names,
        "expansions": task.expansions,
        "best": (best[0], [op.name for op in best[1].extract_solution()]),
        "edges": dict(task.edges),
        "near": set(task.near),
    }


def both(
    world: WorldModel, table: Any, k: int, budget: float, clearance: Any = None
) -> tuple[dict[str, Any], dict[str, Any]]:
    clearance = clearance or world_clearance(world)
    out = []
    for compiled in (False, True):
        task, h = leg_task(world, table, clearance, k)
        task.budget = budget
        out.append(outcome(task, h, compiled))
    return out[0], out[1]


CASES = [
    ("open", 4.0, 0, "straight", 0, math.inf),
    ("cluttered", 5.0, 1, "straight", 16, math.inf),
    ("cluttered", 6.0, 2, "arc", 40, math.inf),
    ("cluttered", 5.0, 3, "straight", 7, 12),  # stopped by the budget
    ("cluttered", 5.0, 8, "straight", 4, 100),  # ... a partial plan
    ("narrow", 4.0, 4, "straight", 32, math.inf),
    ("narrow", 5.0, 5, "arc", 8, math.inf),
    ("enclosed", 3.0, 6, "straight", 0, math.inf),  # unsolvable
]


@pytest.mark.parametrize(("kind", "side", "seed", "shape", "k", "budget"), CASES)
def test_the_compiled_search_finds_what_pyperplan_finds(kind, side, seed, shape, k, budget) -> None:
    table = STRAIGHT if shape == "straight" else ARC
    assert table is not None
    world = world_of(kind, side, seed)
    plain, compiled = both(world, table, k, budget)
    assert compiled == plain
    expected = {"enclosed": "unsolvable"}.get(kind, "timeout" if budget < math.inf else "solved")
    assert compiled["status"] == expected
    if expected == "solved":  # valid on the lattice the search generated (the export's)
        task, _ = leg_task(world, table, world_clearance(world), k)
        task.budget = budget
        plan = lattice_search.search(task, _)
        task.operators = task.operators_seen()
        assert plan is not None
        assert validate_plan(task, [op.name for op in plan]) == (True, "valid")


def test_the_off_goals_tier_reads_the_same_clearance_and_finds_the_same_plan() -> None:
    world = world_of("cluttered", 5.0, 7)
    for x, y in [(0.3, -0.4), (1.2, 1.0), (1.6, 1.9)]:
        world.add_contact((x, y))
    world.add_suspected([(1.0, 1.3), (1.05, 1.3), (1.1, 1.3), (-0.5, 0.2)])
    goals = [(1.7, 1.7)]
    rng = np.random.default_rng(7)
    pts = rng.uniform(-2.7, 2.7, (20_000, 2))
    for tier in [*tiers(True), Tier("off-goals")]:
        clearance = tier_clearance(world, tier, goals)
        assert isinstance(clearance, GridClearance)
        assert np.array_equal(clearance.grids()(pts), clearance(pts))
    assert STRAIGHT is not None
    plain, compiled = both(
        world, STRAIGHT, 12, math.inf, tier_clearance(world, Tier("off-goals"), goals)
    )
    assert compiled == plain and compiled["status"] == "solved"


def test_remainder_is_cpython_math_remainder_bit_for_bit() -> None:
    rng = np.random.default_rng(0)
    xs = [*rng.uniform(-20, 20, 2000), *(n * math.pi / 2 for n in range(-9, 10))]
    xs += [(n + 0.5) * 2 * math.pi for n in range(-5, 5)] + [0.0, -0.0, 1e-300]
    for y in (math.pi, 2 * math.pi, 0.1):
        for x in xs:
            got = lattice_search_kernel.remainder(float(x), y)
            want = math.remainder(float(x), y)
            assert got == want and math.copysign(1, got) == math.copysign(1, want), (x, y)


def test_the_motion_cache_keeps_the_same_plans_across_a_change() -> None:
    """Two searches sharing a cache, the world changed between them: the compiled search
    through its store finds what pyperplan finds through its own, and what a fresh one does."""
    assert STRAIGHT is not None
    world = world_of("cluttered", 5.0, 8)
    grid = LatticeGrid(world.bounds, SETTINGS)
    caches = {
        False: MotionCache(grid, STRAIGHT, SETTINGS.margin),
        True: MotionCache(grid, STRAIGHT, SETTINGS.margin),
    }
    clearance = world_clearance(world)
    dropped = 0
    for change in range(3):
        at = clearance(grid.centres)
        got = {}
        kept = len(caches[False].free)
        for cache in caches.values():
            cache.refresh(at, world.version)
        dropped += kept - len(caches[False].free)
        if change:  # both forgot the same states near the change
            assert set(caches[True].compiled_free().numbers().tolist()) == set(caches[False].free)
        for compiled, cache in caches.items():
            task, h = leg_task(world, STRAIGHT, clearance, 4, cache)
            got[compiled] = outcome(task, h, compiled)
        fresh_task, fresh_h = leg_task(world, STRAIGHT, clearance, 4)
        assert got[True] == got[False] == outcome(fresh_task, fresh_h, True)
        plan = got[True]["plan"]
        if not plan:
            assert change > 0  # (cut off by the contacts)
            break
        # something sensed on the way, a few moves ahead: some cached states are forgotten
        state = int(plan[min(6, len(plan) - 2)].split()[2][1:])
        x, y = grid.centre(*grid.decode(state)[:2])
        world.add_contact((float(x) + 0.15, float(y)))
    assert len(caches[True].compiled_free()) > 0 and dropped > 0


def test_planner_and_repair_plan_the_same_with_and_without_the_compiled_search(monkeypatch) -> None:
    assert STRAIGHT is not None
    bounds = Bounds(-3, 3, -3, 3)
    runs = []
    for on in (False, True):
        monkeypatch.setattr(lattice_search, "AVAILABLE", on)
        world = WorldModel(bounds, [Circle(0.0, 0.8, 0.3), Circle(-1.0, -0.6, 0.25)])
        p = LatticePlanner(bounds, SETTINGS)
        legs = [LegGoal(0, -2.2, 2.0, 0.1)]
        first = p.plan(
            STRAIGHT, world_clearance(world), world.version, (2.2, -2.0, math.pi), legs, True
        )
        moves = [a for a in first.actions if a.name == "move"]
        pose, rest = moves[1].target, first.actions[first.actions.index(moves[1]) + 1 :]
        ahead = [a for a in rest if a.name == "move"][6].target
        world.add_contact((ahead[0], ahead[1]))
        again = p.plan(
            STRAIGHT, world_clearance(world), world.version, pose, legs, True, previous=rest
        )
        runs.append(
            (
                first.actions,
                first.expansions,
                again.actions,
                again.expansions,
                again.repaired,
                sorted(again.graph.edges) if again.graph else None,
            )
        )
    assert runs[0] == runs[1]
    assert runs[1][4]  # the second was a repair


def test_cancel_and_deadline_stop_the_compiled_search() -> None:
    assert STRAIGHT is not None
    world = world_of("cluttered", 5.0, 9)
    task, h = leg_task(world, STRAIGHT, world_clearance(world), 0)
    flag = threading.Event()
    flag.set()
    task.cancel = flag
    with pytest.raises(SearchStopped) as stop:
        lattice_search.search(task, h)
    assert stop.value.status == "cancelled"
    task, h = leg_task(world, STRAIGHT, world_clearance(world), 0)
    task.deadline = 0.0
    with pytest.raises(SearchStopped) as stop:
        lattice_search.search(task, h)
    assert stop.value.status == "timeout"


def test_a_plain_clearance_callable_keeps_pyperplans_search() -> None:
    assert STRAIGHT is not None
    world = world_of("open", 4.0, 0)
    task, h = leg_task(world, STRAIGHT, world.clearance_at, 0)
    assert not lattice_search.applies(task, h)
    task, h = leg_task(world, STRAIGHT, world_clearance(world), 0)
    assert lattice_search.applies(task, h)

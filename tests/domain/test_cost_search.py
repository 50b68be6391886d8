"""The one search: the compiled kernel finds what the pure-Python weighted A* on costs
(``cost_astar``) finds, action for action and at the same cost, on seeded scenes (open,
cluttered, narrow, enclosed, stopped by the budget); the planner's plan and its replan are the
same either way; what the motion cache keeps between replans is what a fresh evaluation gives; the
heuristic's compiled parts equal their Python forms."""

from __future__ import annotations

import math
import threading
from typing import Any

import numpy as np
import pytest

from domain.navigation import LatticeGrid, NavigationSettings, Plan, Planner, PlanRequest
from domain.navigation import search as searches
from domain.navigation.lattice.costs import kernel_table, lethal_costs, risk_costs
from domain.navigation.lattice.states import LatticeState, StatePool, at_fact
from domain.navigation.search import heuristic as heuristics
from domain.navigation.search.heuristic import (
    cells_within,
    state_heuristic,
    way_at,
    way_fill,
    way_of,
    weighted_geodesic,
)
from domain.pyperplan_adapter import SearchStopped
from domain.world import CostmapSettings, RangeObservation, WorldModel
from sim.world import Bounds
from tests.domain.lattice_scenes import (
    ARC,
    SETTINGS,
    STRAIGHT,
    ahead,
    legs,
    looked_round,
    scene,
    sense_post,
)

compiled_only = pytest.mark.skipif(not searches.AVAILABLE, reason="numba kernels are off")


def leg(kind: str, side: float, seed: int, shape: str, k: int, near: bool) -> tuple[Any, Any]:
    """One leg as the planner sets it up: from heading bin ``k`` near one corner of a seeded
    scene to near the other, with the risk of never-observed space round the start (``near``)
    or without; its task and obstacle heuristic."""
    bounds, obstacles = scene(kind, side, seed)
    world = WorldModel(bounds, obstacles, SETTINGS.costmap)
    table = STRAIGHT if shape == "straight" else ARC
    h = side / 2
    p = Planner(bounds, SETTINGS)
    start = (*p.grid.cell(-h + 1.0, -h + 1.0), k)
    inputs = p.inputs(world, table)
    cache = p.cache(table, world, inputs)
    goal = legs([(h - 0.8, h - 0.8)])[0]
    task = p.task(table, inputs, cache, start, goal, True, math.inf, None)
    i, j, _ = start
    here = p.grid.centre(i, j)
    distances = p.heuristic_map(table, world, goal, (float(here[0]), float(here[1])))
    return task, p.leg_heuristic(task, distances)


def outcome(
    case: tuple[Any, ...], compiled: bool, stall: searches.Stall | None = None
) -> dict[str, Any]:
    """What one search shows: how it ended, its plan (operator names and costs), the best node
    (the anytime answer), the lattice it generated (the PDDL export's) and its expansions."""
    *where, budget = case
    task, heuristic = leg(*where)
    found = searches.run(
        task, heuristic, "cost", SETTINGS.search.weight, budget, compiled=compiled, stall=stall
    )
    plan = found.plan or []
    return {
        "status": found.status,
        "plan": [op.name for op in plan],
        "costs": [op.cost for op in plan],
        "best_h": found.best_h,
        "best": [op.name for op in found.best] if found.status == "budget" else None,
        "edges": dict(task.edges),
        "near": set(task.near),
        "expansions": found.expansions,
    }


CASES = {
    "open-facing-it": ("open", 3.0, 0, "straight", 48, False, 50_000),
    "open-turning-blind": ("open", 3.0, 0, "straight", 0, True, 50_000),
    "cluttered-13": ("cluttered", 3.5, 13, "straight", 27, True, 50_000),
    "cluttered-14-arc": ("cluttered", 3.5, 14, "arc", 34, True, 50_000),
    "cluttered-17-arc": ("cluttered", 4.0, 17, "arc", 55, True, 50_000),
    "cluttered-2-arc-seen": ("cluttered", 4.0, 2, "arc", 40, False, 50_000),
    "narrow-4": ("narrow", 3.5, 4, "straight", 32, True, 50_000),
    "enclosed": ("enclosed", 3.0, 6, "straight", 0, True, 50_000),  # no plan exists
    "budget-10": ("cluttered", 3.5, 10, "straight", 6, True, 150),  # stopped by the budget
}
EXPECTED = {"enclosed": "exhausted", "budget-10": "budget"}


@compiled_only
@pytest.mark.parametrize("name", list(CASES))
def test_the_compiled_search_finds_what_the_python_cost_search_finds(name: str) -> None:
    case = CASES[name]
    python, kernel = outcome(case, compiled=False), outcome(case, compiled=True)
    assert kernel["status"] == python["status"] == EXPECTED.get(name, "solved")
    assert kernel["plan"] == python["plan"]  # action for action
    # The same costs: the kernel's are differences of its accumulated g, so equal to rounding.
    np.testing.assert_allclose(kernel["costs"], python["costs"], rtol=0, atol=1e-12)
    assert sum(kernel["costs"]) == pytest.approx(sum(python["costs"]), rel=1e-12)
    assert kernel["best_h"] == python["best_h"] and kernel["best"] == python["best"]
    assert kernel["near"] == python["near"]
    assert kernel["edges"].keys() == python["edges"].keys()
    for state, edges in python["edges"].items():  # the same successors, at the same costs
        assert [(b, p) for b, p, _ in kernel["edges"][state]] == [(b, p) for b, p, _ in edges]
        np.testing.assert_allclose(
            [c for *_, c in kernel["edges"][state]], [c for *_, c in edges], rtol=0, atol=1e-12
        )
    if kernel["status"] == "solved":
        assert kernel["plan"][-1].startswith("(visit ") and len(kernel["plan"]) > 3
        assert kernel["expansions"] == python["expansions"]
    if kernel["status"] == "budget":
        assert kernel["best"]  # an anytime answer towards the goal


@compiled_only
def test_a_motion_cache_that_starts_afresh_mid_search_changes_no_plan(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A cache whose parts keep only 64 states' rows (a worker with little memory) starts
    afresh many times within one search: the search finds the same plan at the same costs."""
    from domain.navigation.lattice import cache

    case = CASES["cluttered-13"]
    roomy = outcome(case, compiled=True)
    monkeypatch.setattr(cache, "ROWS_LIMIT", 64)
    small = outcome(case, compiled=True)
    assert roomy["status"] == small["status"] == "solved" and roomy["expansions"] > 64
    assert small["plan"] == roomy["plan"]
    np.testing.assert_allclose(small["costs"], roomy["costs"], rtol=0, atol=1e-12)


@compiled_only
@pytest.mark.parametrize("name", ["cluttered-13", "cluttered-17-arc", "narrow-4", "enclosed"])
def test_a_stalled_search_goes_on_greedier_the_same_compiled_or_not(name: str) -> None:
    """Past ``after`` expansions the open list is re-keyed at the higher weight: the compiled
    and the Python search still expand the same states into the same plan, a plan exists as
    it did, found another way than at one weight (not always in fewer expansions: a greedier
    order can run into a dead end first; ``bench.missions`` shows what it saves), and an
    enclosed goal is still proven out of reach (the weight changes the order, never the
    states there are)."""
    case = CASES[name]
    steady = outcome(case, compiled=True)
    stall = searches.Stall(after=40, weight=5.0)
    python, kernel = outcome(case, False, stall), outcome(case, True, stall)
    assert kernel["status"] == python["status"] == steady["status"]
    assert kernel["plan"] == python["plan"] and kernel["expansions"] == python["expansions"]
    assert kernel["best"] == python["best"] and kernel["edges"].keys() == python["edges"].keys()
    if steady["status"] == "solved":
        assert steady["expansions"] > 40  # (else the stall never came)
        assert (kernel["plan"], kernel["expansions"]) != (steady["plan"], steady["expansions"])
        assert kernel["plan"][-1].startswith("(visit ")
    else:
        assert kernel["expansions"] == steady["expansions"]  # every reachable state, either way


@compiled_only
def test_a_search_stopped_by_its_budget_reports_as_many_expansions_either_way() -> None:
    case = CASES["budget-10"]
    python, kernel = outcome(case, compiled=False), outcome(case, compiled=True)
    assert python["expansions"] == case[-1]
    assert kernel["expansions"] == python["expansions"]


def first_and_replan(compiled: bool, monkeypatch: pytest.MonkeyPatch) -> tuple[Any, ...]:
    """A plan across a seeded cluttered scene the robot has looked round; then, two moves on, a
    post sensed a metre ahead on it, and the replan from there (the motion cache kept)."""
    monkeypatch.setattr(searches, "AVAILABLE", compiled)
    bounds, obstacles = scene("cluttered", 5.0, 13)
    world = looked_round(WorldModel(bounds, obstacles, SETTINGS.costmap))
    p = Planner(bounds, SETTINGS)
    goals = legs([(1.7, 1.7)])
    first = p.plan(PlanRequest((-1.6, -1.6, 0.8), STRAIGHT, goals, True, world))
    assert isinstance(first, Plan)
    moves = [a for a in first.actions if a.name == "move"]
    pose = moves[1].target
    rest = first.actions[first.actions.index(moves[1]) + 1 :]
    sense_post(world, *ahead([a for a in rest if a.name == "move"], pose))
    again = p.plan(PlanRequest(pose, STRAIGHT, goals, True, world))
    assert isinstance(again, Plan)
    return tuple(
        (
            out.pddl_plan,
            [round(a.cost, 9) for a in out.actions],
            out.expansions,
            out.partial,
        )
        for out in (first, again)
    )


@compiled_only
def test_the_planner_plans_and_replans_the_same_with_and_without_the_compiled_search(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    python = first_and_replan(False, monkeypatch)
    kernel = first_and_replan(True, monkeypatch)
    assert kernel == python
    assert kernel[0][0] != kernel[1][0] and kernel[1][2] > 0  # the post changed the way


@pytest.mark.parametrize("seed", [3, 4])
def test_what_the_motion_cache_keeps_is_what_a_fresh_evaluation_gives(seed: int) -> None:
    """A plan, then something sensed beside its middle and a contact near the robot, and a
    replan by the same planner: every state's motions its cache still holds (valid motions,
    their lethal and their risk costs) are what the new costmap gives them, and the replan is
    the one a fresh planner makes."""
    bounds, obstacles = scene("cluttered", 5.0, seed)
    world = WorldModel(bounds, obstacles[::2], SETTINGS.costmap)
    p = Planner(bounds, SETTINGS)
    goals = legs([(1.7, 1.7)])
    pose = (-1.6, -1.6, 0.8)
    first = p.plan(PlanRequest(pose, STRAIGHT, goals, True, world))
    assert isinstance(first, Plan)
    moves = [a for a in first.actions if a.name == "move"]
    x, y, _ = moves[len(moves) // 2].target
    for _ in range(3):
        world.integrate([RangeObservation((x + 0.6, y + 0.1), math.pi, 0.0, 1.0, 0.5, True)])
    world.add_contact(pose, (0.0, 0.0, 0.0), 2, "left", 1.0)
    again = p.plan(PlanRequest(pose, STRAIGHT, goals, True, world))
    fresh = Planner(bounds, SETTINGS).plan(PlanRequest(pose, STRAIGHT, goals, True, world))
    assert isinstance(again, Plan) and isinstance(fresh, Plan)
    assert again.pddl_plan == fresh.pddl_plan and again.expansions == fresh.expansions
    inputs = p.inputs(world, STRAIGHT, pose)  # priced from the robot, as the plan was
    cache = p.cache(STRAIGHT, world, inputs)
    kt = kernel_table(STRAIGHT, SETTINGS.margin)
    lethal, risky = cache.lethal, cache.risk
    numbers = lethal.index.numbers().tolist()
    assert len(numbers) > 50 and len(risky) > 50
    for number in numbers:
        row = lethal.index.get(number)
        assert row is not None
        bits, base = lethal_costs(number, inputs, kt)
        assert int(lethal.ints[row]) == bits, p.grid.decode(number)
        np.testing.assert_array_equal(lethal.floats[row], base)
    for number in risky.index.numbers().tolist():
        row = risky.index.get(number)
        assert row is not None
        np.testing.assert_array_equal(risky.floats[row], risk_costs(number, inputs, kt))


@compiled_only
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_heuristic_s_kernels_equal_their_python_forms(
    seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The bucket-queue Dijkstra gives the heap Dijkstra's distances bit for bit (random
    passable cells and weights, several sources); a state's compiled heuristic value equals
    its Python form's."""
    rng = np.random.default_rng(seed)
    for shape in [(1, 9), (7, 1), (40, 33), (90, 70)]:
        ok = rng.random(shape) > 0.25
        weights = 1.0 + rng.random(shape) * rng.choice([0.0, 1.0, 9.0])
        sources = [(int(rng.integers(shape[0])), int(rng.integers(shape[1]))) for _ in range(2)]
        got = weighted_geodesic(ok, weights, sources, 0.05)
        with monkeypatch.context() as m:
            m.setattr(heuristics, "AVAILABLE", False)
            want = weighted_geodesic(ok, weights, sources, 0.05)
        assert np.array_equal(got, want)  # inf where cut off, and the same floats elsewhere
        assert np.isfinite(want).sum() >= 1
    task, heuristic = leg("cluttered", 4.0, seed, "straight", 5, True)
    numbers = rng.integers(0, task.grid.size, 400).tolist()
    for number in numbers:
        args = (heuristic.dims, heuristic.hf, heuristic.values, heuristic.risk)
        assert state_heuristic(number, *args) == state_heuristic.py_func(number, *args)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_cells_way_from_its_neighbours_is_the_whole_maps_gradient(seed: int) -> None:
    """The heuristic turns a state onto the map's way at its own cell only: that way, from the
    cell's neighbours (edges and cut-off cells included), is numpy's gradient of the whole map,
    the same float compiled and not, and numpy's to its last bit (numpy's arctan2 over an array
    takes SIMD code on CPUs with AVX-512, which may round the other way from the C library's
    arctan2, one unit in the last place)."""
    rng = np.random.default_rng(seed)
    for shape in [(2, 9), (9, 2), (40, 33)]:
        values = rng.random(shape) * 20.0
        values[rng.random(shape) < 0.2] = math.inf
        want = way_of(values)
        flat, fill = values.ravel(), way_fill(values)
        got = np.empty(shape)
        for i in range(shape[0]):
            for j in range(shape[1]):
                got[i, j] = way_at(flat, shape[0], shape[1], i, j, fill)
                assert got[i, j] == way_at.py_func(flat, shape[0], shape[1], i, j, fill)
        np.testing.assert_array_max_ulp(got, want, maxulp=1)


@compiled_only
def test_several_sources_never_fill_a_bucket_past_the_cells(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A bucket holds one entry per cell. A row of sources lowers each cell beside it twice
    within one bucket; the kernel's own loop run as Python would raise IndexError where,
    compiled, it wrote past the bucket."""
    ok = np.ones((3, 3), dtype=bool)
    ones = np.ones((3, 3))
    sources = [(1, 0), (1, 1), (1, 2)]
    with monkeypatch.context() as m:
        m.setattr(heuristics, "AVAILABLE", False)
        want = weighted_geodesic(ok, ones, sources, 0.05)
    monkeypatch.setattr(heuristics, "_dijkstra", heuristics._dijkstra.py_func)
    assert np.array_equal(weighted_geodesic(ok, ones, sources, 0.05), want)


def test_distances_go_round_a_wall() -> None:
    ok = np.ones((9, 9), dtype=bool)
    ok[4, :8] = False  # a wall with a gap at j = 8
    d = weighted_geodesic(ok, np.ones((9, 9)), [(0, 0)], 1.0)
    assert d[8, 0] > 8 * 1.0  # round the end of the wall, not through it
    assert np.isclose(d[3, 0], 3.0) and np.isclose(d[2, 2], 2 * np.sqrt(2))
    heavy = weighted_geodesic(ok, np.where(ok, 3.0, 1.0), [(0, 0)], 1.0)
    assert np.isclose(heavy[3, 0], 9.0)  # a step costs its length times the cells' weight


@pytest.mark.parametrize("seed", [0, 1])
def test_cells_within_finds_what_a_scan_of_every_cell_finds(seed: int) -> None:
    """The box search round a point returns exactly the cells a scan of the grid returns,
    points off the grid and radii below a cell included."""
    rng = np.random.default_rng(seed)
    for _ in range(60):
        x0, y0 = rng.uniform(-6.0, -1.0, 2)
        x1, y1 = rng.uniform(1.0, 6.0, 2)
        bounds = Bounds(float(x0), float(x1), float(y0), float(y1))
        r = float(rng.choice([0.033, 0.05, 0.1]))
        grid = LatticeGrid(
            bounds, NavigationSettings(resolution=r, costmap=CostmapSettings(resolution=r))
        )
        point = (float(rng.uniform(x0 - 1, x1 + 1)), float(rng.uniform(y0 - 1, y1 + 1)))
        radius = float(rng.choice([0.0, 0.01, rng.uniform(0, 1.5)]))
        c = grid.centres
        want = np.flatnonzero(np.hypot(c[:, 0] - point[0], c[:, 1] - point[1]) <= radius)
        np.testing.assert_array_equal(cells_within(grid, point, radius), want)


@compiled_only
def test_remainder_is_cpython_math_remainder_bit_for_bit() -> None:
    rng = np.random.default_rng(0)
    xs = [*rng.uniform(-20, 20, 2000), *(n * math.pi / 2 for n in range(-9, 10))]
    xs += [(n + 0.5) * 2 * math.pi for n in range(-5, 5)] + [0.0, -0.0, 1e-300]
    for y in (math.pi, 2 * math.pi, 0.1):
        for x in xs:
            got = heuristics._remainder(float(x), y)
            want = math.remainder(float(x), y)
            assert got == want and math.copysign(1, got) == math.copysign(1, want), (x, y)


@compiled_only
def test_cancel_and_deadline_stop_the_compiled_search() -> None:
    case = CASES["cluttered-13"][:-1]
    task, h = leg(*case)
    flag = threading.Event()
    flag.set()
    task.cancel = flag
    with pytest.raises(SearchStopped) as stop:
        searches.run(task, h, "cost", 1.5, 50_000, compiled=True)
    assert stop.value.status == "cancelled"
    task, h = leg(*case)
    task.deadline = 0.0  # long past
    with pytest.raises(SearchStopped) as stop:
        searches.run(task, h, "cost", 1.5, 50_000, compiled=True)
    assert stop.value.status == "timeout"


def test_a_pool_hands_out_one_state_per_number_equal_to_the_plain_frozenset() -> None:
    pool = StatePool(limit=2)
    a = pool.state(7)
    assert pool.state(7) is a and isinstance(a, LatticeState) and a.number == 7
    assert a == frozenset([at_fact(7)]) and hash(a) == hash(frozenset([at_fact(7)]))
    pool.state(8)
    pool.state(9)  # over the limit: the pool starts afresh, equal states are made again
    assert pool.state(7) == a and len(pool.states) <= 2
    with pytest.raises(ValueError, match="limit"):
        StatePool(limit=0)


def test_a_bins_distinct_points_give_back_every_swept_point() -> None:
    for k in (0, 13, 63):
        unique, inverse = STRAIGHT.distinct(k)
        assert np.array_equal(unique[inverse], STRAIGHT.points[k])
        assert len(np.unique(unique, axis=0)) == len(unique) < len(STRAIGHT.points[k])


def test_goal_states_are_those_with_the_head_on_the_goal() -> None:
    task, _ = leg("open", 3.0, 0, "straight", 0, False)
    near = task.near_states()
    assert near.size > 0 and np.all(np.diff(near) > 0)
    grid = task.grid
    got = {int(n) for n in near}
    for k in range(0, grid.settings.orientations, 7):
        for i in range(grid.nx):
            for j in range(grid.ny):
                key = (i, j, k)
                assert (grid.encode(key) in got) == task.is_near(key), key

"""What the planner keeps between searches changes no plan: the successors kept in the motion
cache, the search states shared by number, the duplicates left out of A*-family searches."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pyperplan.search import astar_search, breadth_first_search, greedy_best_first_search

from domain.lattice import LatticeSettings, motion_table
from domain.lattice_cache import MotionCache
from domain.lattice_distances import centroid_need, distance_map
from domain.lattice_heuristic import LatticeHeuristic
from domain.lattice_planner import LatticePlanner
from domain.lattice_states import LatticeState, StatePool, at_fact
from domain.lattice_task import LatticeTask
from domain.pyperplan_adapter import validate_plan
from domain.worldmodel import WorldModel
from primitives.library import load_bundled
from sim.obstacles import Circle
from sim.world import Bounds

LIB = load_bundled()
SETTINGS = LatticeSettings()
STRAIGHT = motion_table(LIB, "straight", (0.0, 0.0, 0.0), SETTINGS)
BOUNDS = Bounds(-2.5, 2.5, -2.5, 2.5)


def scene(seed: int) -> WorldModel:
    rng = np.random.default_rng(seed)
    discs = []
    while len(discs) < 5:
        x, y = rng.uniform(-1.6, 1.6, 2)
        if math.hypot(x + 1.5, y + 1.5) > 0.9 and math.hypot(x - 1.6, y - 1.6) > 0.9:
            discs.append(Circle(float(x), float(y), float(rng.uniform(0.15, 0.35))))
    return WorldModel(BOUNDS, discs)


def leg(world: WorldModel, cache: MotionCache | None, pool: StatePool | None) -> LatticeTask:
    assert STRAIGHT is not None
    grid = LatticePlanner(BOUNDS, SETTINGS).grid
    start = (*grid.cell(-1.5, -1.5), 0)
    m = SETTINGS.margin
    task = LatticeTask(grid, STRAIGHT, world.clearance_at, start, (1.6, 1.6), 0.06, m, 0.0, 0, pool)
    task.at_centres = world.clearance_at(grid.centres)
    if cache is not None:
        task.cache = cache
    return task


def search(task: LatticeTask, world: WorldModel, algorithm, prune: bool):
    assert STRAIGHT is not None
    at = world.clearance_at(task.grid.centres)
    dist = distance_map(task.grid, at, task.goal, centroid_need(STRAIGHT), 0.5)
    h = LatticeHeuristic(task, dist, STRAIGHT.longest_step)
    if prune:
        with task.search_reached(algorithm):
            plan = algorithm(task, h)
    else:
        plan = algorithm(task, h)
    assert plan is not None
    return [op.name for op in plan], task.expansions


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("algorithm", [greedy_best_first_search, astar_search])
def test_leaving_out_duplicates_finds_the_same_plan_in_as_many_expansions(
    seed: int, algorithm
) -> None:
    world = scene(seed)
    plain = search(leg(world, None, None), world, algorithm, prune=False)
    pruned_task = leg(world, None, None)
    pruned = search(pruned_task, world, algorithm, prune=True)
    assert pruned == plain
    assert pruned_task.reached is None  # only while searching
    # ... and the plan is valid on the lattice the search generated (the PDDL export's)
    pruned_task.operators = pruned_task.operators_seen()
    assert validate_plan(pruned_task, pruned[0]) == (True, "valid")


def test_other_searches_get_every_successor() -> None:
    world = scene(0)
    task = leg(world, None, None)
    with task.search_reached(breadth_first_search):
        assert task.reached is None
        first = task.get_successor_states(task.initial_state)
    assert len(first) >= 10


@pytest.mark.parametrize("seed", [3, 4])
def test_successors_kept_in_the_cache_equal_fresh_ones_after_a_local_change(seed: int) -> None:
    world = scene(seed)
    grid = LatticePlanner(BOUNDS, SETTINGS).grid
    assert STRAIGHT is not None
    pool = StatePool()
    cache = MotionCache(grid, STRAIGHT, SETTINGS.margin, pool)
    cache.refresh(world.clearance_at(grid.centres), world.version)
    first = search(leg(world, cache, pool), world, greedy_best_first_search, prune=True)
    assert len(cache.moves) > 20
    # something sensed beside the plan's middle: the cache forgets the states near it only
    rng = np.random.default_rng(seed)
    kept_before = len(cache.moves)
    x, y = rng.uniform(-0.5, 0.5, 2)
    world.add_contact((float(x), float(y)))
    cache.refresh(world.clearance_at(grid.centres), world.version)
    assert 0 < len(cache.moves) <= kept_before
    again = leg(world, cache, pool)
    replanned = search(again, world, greedy_best_first_search, prune=True)
    fresh = search(leg(world, None, None), world, greedy_best_first_search, prune=True)
    assert replanned == fresh  # the same plan, as many expansions, as with nothing kept
    assert first[0]
    check = leg(world, None, None)
    for number, (moves, edges) in cache.moves.items():
        want_moves, want_edges = check.moves_from(number)
        assert edges == want_edges, grid.decode(number)
        assert [(op.name, s.number) for op, s in moves] == [
            (op.name, s.number) for op, s in want_moves
        ]


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


def test_the_motion_cache_keeps_the_newest_successors_up_to_its_limit() -> None:
    assert STRAIGHT is not None
    grid = LatticePlanner(BOUNDS, SETTINGS).grid
    cache = MotionCache(grid, STRAIGHT, SETTINGS.margin, moves_limit=4)
    for number in range(10):
        cache.keep_moves(number, ([], []))
    assert len(cache.moves) <= 4 and 9 in cache.moves and 0 not in cache.moves
    with pytest.raises(ValueError, match="moves_limit"):
        MotionCache(grid, STRAIGHT, SETTINGS.margin, moves_limit=0)


def test_a_bins_distinct_points_give_back_every_swept_point() -> None:
    assert STRAIGHT is not None
    for k in (0, 13, 63):
        unique, inverse = STRAIGHT.distinct(k)
        assert np.array_equal(unique[inverse], STRAIGHT.points[k])
        assert len(np.unique(unique, axis=0)) == len(unique) < len(STRAIGHT.points[k])


def test_a_cache_first_refreshed_by_a_window_keeps_no_verdict_it_cannot_compare() -> None:
    """A repair may be the first to use a cache (a new clearance family): it has no clearance
    to compare with, so it keeps nothing it held, and later changes in the window are seen."""
    world = scene(5)
    grid = LatticePlanner(BOUNDS, SETTINGS).grid
    assert STRAIGHT is not None
    pool = StatePool()
    cache = MotionCache(grid, STRAIGHT, SETTINGS.margin, pool)
    window = (slice(10, 60), slice(10, 60))
    centres = grid.centres.reshape(grid.nx, grid.ny, 2)[window].reshape(-1, 2)
    cache.refresh_window(world.clearance_at(centres), window)
    search(leg(world, cache, pool), world, greedy_best_first_search, prune=True)
    held = set(cache.free)
    assert held
    # something sensed inside the window, then a second window refresh (the next repair)
    world.add_contact(tuple(float(v) for v in grid.centre(35, 35)))
    cache.refresh_window(world.clearance_at(centres), window)
    assert len(cache.free) < len(held)
    check = leg(world, None, None)
    for number, free in cache.free.items():
        i, j = grid.decode(number)[:2]
        if 10 <= i < 60 and 10 <= j < 60:
            assert np.array_equal(free, check.free_mask(grid.decode(number))), (i, j)
    # ... and a full refresh forgets the states it knows nothing about round the window
    cache.refresh(world.clearance_at(grid.centres), world.version)
    kept = leg(world, cache, pool)
    assert search(kept, world, greedy_best_first_search, prune=True) == search(
        leg(world, None, None), world, greedy_best_first_search, prune=True
    )

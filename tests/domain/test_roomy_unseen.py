"""The roomy map's unknown cost: along a way round, a metre through cells no range reading has
crossed counts ``LatticeSettings.unknown_cost`` metres, so of two ways round the one through
sensed space is taken (hidden obstacles lie in the unsensed one) and neither is refused."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from domain.clearance_tiers import Tier, tier_clearance, unseen_at
from domain.grid_clearance import ClearanceGrids, GridClearance, unseen_of
from domain.lattice import LatticeGrid, LatticeSettings
from domain.lattice_distances import centroid_need, distance_map, roomy_map
from domain.lattice_plan import LatticePlan
from domain.lattice_planner import LatticePlanner
from domain.observation import RangeObservation
from domain.worldmodel import WorldModel
from sim.world import Bounds
from tests.domain.test_roomy_map import AT_SLOT, BOUNDS, GOAL, POCKET, SENSED, STRAIGHT, clearance

Unseen = Callable[[np.ndarray], np.ndarray]
WORLD = WorldModel(BOUNDS, POCKET)


def pocket(unseen: Unseen | None) -> GridClearance:
    """The pocket's clearance (``test_roomy_map.clearance``) with its compiled form, whose
    world has not sensed where ``unseen`` says."""

    def grids() -> ClearanceGrids:
        return ClearanceGrids.of(WORLD.clearance() - SENSED, WORLD.grid, WORLD.bounds)

    return GridClearance(clearance, grids, unseen)


def south(points: np.ndarray) -> np.ndarray:
    """Unsensed: south of the pocket (its south wall's outer face is at y = -1.25)."""
    out: np.ndarray = np.asarray(points)[:, 1] < -1.2
    return out


def north(points: np.ndarray) -> np.ndarray:
    out: np.ndarray = np.asarray(points)[:, 1] > 1.2
    return out


def plan_from_slot(unseen: Unseen | None, cost: float) -> LatticePlan:
    """The short plan from the bent slot's mouth, where the usual map's way is lost."""
    assert STRAIGHT is not None
    planner = LatticePlanner(BOUNDS, LatticeSettings(unknown_cost=cost), time_limit=120.0)
    return planner.plan(STRAIGHT, pocket(unseen), 0, AT_SLOT, (GOAL,), True, quick=True)


def way(plan: LatticePlan) -> tuple[float, float]:
    """The lowest and highest y the plan's moves reach."""
    assert plan.solved and not plan.partial, plan.reason
    assert plan.actions[-1].name == "visit" and plan.actions[-1].goal == 0
    ys = [a.target[1] for a in plan.actions]
    assert min(a.target[0] for a in plan.actions) < -1.5  # out of the pocket's open end
    return min(ys), max(ys)


def test_the_way_round_goes_through_sensed_space() -> None:
    """Out of the pocket the goal lies round its south wall or (a little longer) its north one.
    With the south unsensed, the roomy search goes round the north; with the north unsensed,
    or every metre costing the same (the map before the unknown cost), round the south."""
    low, high = way(plan_from_slot(south, 2.0))
    assert low > -1.2 and high > 1.3  # north of the pocket, never south of it
    for unseen, cost in ((north, 2.0), (south, 1.0), (None, 2.0)):
        low, high = way(plan_from_slot(unseen, cost))
        assert low < -1.3 and high < 1.2, (unseen, cost)


def test_a_way_through_unsensed_space_only_is_still_taken() -> None:
    """Nothing is refused: with everything unsensed the roomy search still finds the whole
    way round, on the side it takes with everything sensed (the south, the shorter)."""
    for unseen in (lambda p: np.ones(len(p), dtype=bool), None):
        low, high = way(plan_from_slot(unseen, 3.0))
        assert low < -1.3 and high < 1.2


def maps(unseen: np.ndarray | None, cost: float) -> tuple[LatticeGrid, np.ndarray, np.ndarray]:
    assert STRAIGHT is not None
    grid = LatticeGrid(BOUNDS, LatticeSettings())
    at = clearance(grid.centres)
    to, free = (GOAL.x, GOAL.y), float(np.linalg.norm(STRAIGHT.offset)) + GOAL.tolerance
    start = (AT_SLOT[0], AT_SLOT[1])
    usual = distance_map(grid, at, to, centroid_need(STRAIGHT), free, start)
    margin = LatticeSettings().margin
    return grid, usual, roomy_map(grid, at, to, STRAIGHT, margin, free, start, usual, unseen, cost)


def test_unsensed_cells_cost_more_and_no_cell_is_pruned() -> None:
    grid, usual, plain = maps(None, 1.0)
    unseen = south(grid.centres)
    _, _, costly = maps(unseen, 2.5)
    assert np.array_equal(np.isfinite(costly), np.isfinite(usual))  # nothing pruned
    assert np.all(costly[np.isfinite(costly)] >= plain[np.isfinite(plain)] - 1e-9)
    # In the pocket the roomy way goes out of its west end and round its south side: the
    # south unsensed, it costs more; the north unsensed, it crosses no unsensed cell.
    i, j = grid.cell(-1.0, 0.0)
    _, _, northern = maps(north(grid.centres), 2.5)
    assert costly[i, j] > plain[i, j] + 1.0 and northern[i, j] == plain[i, j]
    # A cost of 1, or nothing unsensed, is the map without the unknown cost.
    assert np.array_equal(maps(unseen, 1.0)[2], plain)
    assert np.array_equal(maps(np.zeros_like(unseen), 2.5)[2], plain)


def test_whether_a_roomy_way_exists_is_judged_by_length_alone() -> None:
    """From a start whose roomy way is the usual way, the roomy map is the usual map (the same
    search again is not run), however costly the unsensed cells make it."""
    assert STRAIGHT is not None
    grid = LatticeGrid(BOUNDS, LatticeSettings())
    at = clearance(grid.centres)
    to, free = (GOAL.x, GOAL.y), float(np.linalg.norm(STRAIGHT.offset)) + GOAL.tolerance
    start = (3.5, 3.5)  # north-east of the pocket, in the open
    usual = distance_map(grid, at, to, centroid_need(STRAIGHT), free, start)
    margin = LatticeSettings().margin
    everywhere = np.ones(len(grid.centres), dtype=bool)
    got = roomy_map(grid, at, to, STRAIGHT, margin, free, start, usual, everywhere, 3.0)
    assert got is usual


def test_unknown_cost_is_a_validated_setting() -> None:
    assert LatticeSettings().unknown_cost > 1.0  # on by default
    for bad in (0.5, 11.0):
        with pytest.raises(ValueError, match="unknown_cost"):
            LatticeSettings(unknown_cost=bad)


def test_unseen_cells_are_those_no_reading_crossed() -> None:
    world = WorldModel(Bounds(-2.0, 2.0, -2.0, 2.0), [])
    points = np.array([[0.5, 0.0], [1.5, 0.0], [0.0, 1.0], [5.0, 5.0]])
    assert unseen_at(world, points).tolist() == [True, True, True, False]  # off the grid: seen
    world.integrate([RangeObservation((0.0, 0.0), 0.0, 0.0, 1.0, 1.0, False)])  # nothing ahead
    assert unseen_at(world, points).tolist() == [False, True, True, False]
    told = unseen_of(tier_clearance(world, Tier("none")))  # what the planner reads
    assert told is not None and told(points).tolist() == [False, True, True, False]

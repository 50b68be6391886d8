"""The compiled flood fill answers "can the body get there at all?" as the labelling does."""

from __future__ import annotations

import numpy as np
import pytest

from domain import reach_kernel
from domain.lattice import LatticeGrid, LatticeSettings, motion_table
from domain.lattice_reach import Reachability
from primitives.library import load_bundled
from sim.world import Bounds
from tests.domain.disc_scenes import clearance

pytestmark = pytest.mark.skipif(not reach_kernel.AVAILABLE, reason="numba kernels are off")

SETTINGS = LatticeSettings()
TABLE = motion_table(load_bundled(), "straight", (0.0, 0.0, 0.0), SETTINGS)


def ring(x: float, y: float, radius: float, n: int = 40) -> list[tuple[float, float, float]]:
    """Small discs on a circle: a closed pen round (x, y)."""
    a = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return [(x + radius * np.cos(t), y + radius * np.sin(t), 0.06) for t in a]


@pytest.mark.parametrize("seed", range(6))
def test_the_flood_fill_answers_as_the_labelling(seed: int) -> None:
    assert TABLE is not None
    rng = np.random.default_rng(seed)
    grid = LatticeGrid(Bounds(-1.5, 1.5, -1.5, 1.5), SETTINGS)
    discs = [(*rng.uniform(-1.4, 1.4, 2), rng.uniform(0.05, 0.3)) for _ in range(4 + seed)]
    discs += ring(0.9, 0.9, 0.45)  # a pen: goals inside it cannot be reached from outside
    reach = Reachability(grid, TABLE, clearance(grid, discs), margin=0.03)
    reach.flood_budget = 10**9  # the flood answers every question itself
    answers = []
    for _ in range(12):
        start = (int(rng.integers(grid.nx)), int(rng.integers(grid.ny)), int(rng.integers(64)))
        for goal in [(0.9, 0.9), tuple(rng.uniform(-1.4, 1.4, 2)), (-1.2, -1.2)]:
            flood = reach.reaches(start, goal, 0.08, compiled=True)
            labels = reach.reaches(start, goal, 0.08, compiled=False)
            assert flood == labels, (seed, start, goal)
            answers.append(flood)
    assert True in answers and False in answers  # both answers were put to the test


def test_a_start_that_touches_everything_may_reach() -> None:
    assert TABLE is not None
    grid = LatticeGrid(Bounds(-1.0, 1.0, -1.0, 1.0), SETTINGS)
    blocked = np.full(grid.nx * grid.ny, -1.0)  # nowhere may the body lie
    reach = Reachability(grid, TABLE, blocked, margin=0.03)
    assert reach.reaches((20, 20, 0), (0.5, 0.5), 0.08, compiled=True)
    assert reach.reaches((20, 20, 0), (0.5, 0.5), 0.08, compiled=False)


def test_a_flood_over_budget_leaves_the_answer_to_the_labelling() -> None:
    assert TABLE is not None
    grid = LatticeGrid(Bounds(-1.5, 1.5, -1.5, 1.5), SETTINGS)
    reach = Reachability(grid, TABLE, clearance(grid, ring(0.9, 0.9, 0.45)), margin=0.03)
    start, outside, inside = (10, 10, 0), (-1.0, 1.0), (0.9, 0.9)
    reach.flood_budget = 10**9
    assert reach.reaches(start, outside, 0.08) and not reach.reaches(start, inside, 0.08)
    reach.flood_budget = 50  # too few to decide either: the labelling answers, the same
    assert reach._labels is None
    assert reach.reaches(start, outside, 0.08) and not reach.reaches(start, inside, 0.08)
    assert reach._labels is not None  # it did answer


@pytest.mark.parametrize("seed", range(4))
def test_free_configurations_updated_from_an_earlier_world_equal_a_fresh_count(seed: int) -> None:
    """A replan's free configurations are the last ones updated where the clearance changed
    (something sensed: a disc added, one moved away): equal to those made afresh, and so are
    the answers of a Reachability made from the earlier one."""
    from domain.lattice_reach import free_configurations

    assert TABLE is not None
    rng = np.random.default_rng(seed)
    grid = LatticeGrid(Bounds(-2.0, 2.0, -2.0, 2.0), SETTINGS)
    discs = [(*rng.uniform(-1.8, 1.8, 2), rng.uniform(0.05, 0.3)) for _ in range(6)]
    before = clearance(grid, discs)
    first = Reachability(grid, TABLE, before, margin=0.03)
    first._labelled()  # as a question the flood could not answer would
    assert first.labelled
    changed = [*discs[1:], (*rng.uniform(-1.8, 1.8, 2), 0.2)]  # one gone, one found
    after = clearance(grid, changed)
    fresh = free_configurations(grid, TABLE, after, 0.03)
    updated = free_configurations(grid, TABLE, after, 0.03, previous=(before, first._labels[0]))
    assert np.array_equal(updated, fresh)
    assert np.array_equal(
        free_configurations(grid, TABLE, before, 0.03, previous=(before, fresh)), fresh
    )  # nothing changed: kept as it was
    second = Reachability(grid, TABLE, after, margin=0.03, previous=first)
    again = Reachability(grid, TABLE, after, margin=0.03)
    for _ in range(8):
        start = (int(rng.integers(grid.nx)), int(rng.integers(grid.ny)), int(rng.integers(64)))
        goal = tuple(rng.uniform(-1.8, 1.8, 2))
        assert second.reaches(start, goal, 0.08, compiled=False) == again.reaches(
            start, goal, 0.08, compiled=False
        )
    assert second.labelled and np.array_equal(second._labels[0], fresh)

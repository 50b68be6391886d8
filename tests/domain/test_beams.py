"""The cells a tick's beams sweep, found in one pass, are those each beam's samples fall in."""

from __future__ import annotations

import math

import numpy as np
import pytest

from domain.world import Grid, RangeObservation
from domain.world.sensed.beams import arc_cells, hit_points, sector_points, swept_cells
from sim.world import Bounds


@pytest.mark.parametrize("seed", range(100))
def test_swept_cells_equal_each_beams_own_samples(seed: int) -> None:
    rng = np.random.default_rng(seed)
    grid = Grid(Bounds(-3, 3, -2, 2.5), float(rng.choice([0.05, 0.1, 0.07])))
    step = 0.5 * grid.resolution
    readings = []
    for _ in range(int(rng.integers(0, 12))):
        fov = float(rng.choice([0.0, math.radians(10), 1.0]))
        max_range = float(rng.uniform(0.3, 2.5))
        distance = float(rng.uniform(0, max_range))
        obs = RangeObservation(
            tuple(rng.uniform(-3.5, 3.5, 2)),  # sometimes outside the grid
            float(rng.uniform(-7, 7)),
            fov,
            max_range,
            distance,
            True,
        )
        readings.append((obs, distance - float(rng.uniform(-0.1, 0.2))))  # until may be <= 0
    owner, cell = swept_cells(grid, readings, step)
    expected_owner, expected_cell = [], []
    for k, (obs, until) in enumerate(readings):
        cells = np.unique(grid.flat_of(sector_points(obs, until, step)))
        expected_owner += [k] * cells.size
        expected_cell += cells.tolist()
    assert owner.tolist() == expected_owner
    assert cell.tolist() == expected_cell


def test_nothing_to_sweep() -> None:
    grid = Grid(Bounds(-1, 1, -1, 1), 0.05)
    obs = RangeObservation((0.0, 0.0), 0.0, 0.0, 1.0, 0.01, True)
    owner, cell = swept_cells(grid, [(obs, -0.01)], 0.025)
    assert owner.size == 0 and cell.size == 0


@pytest.mark.parametrize("seed", range(100))
def test_arc_cells_equal_each_hits_own_samples(seed: int) -> None:
    rng = np.random.default_rng(1000 + seed)
    grid = Grid(Bounds(-3, 3, -2, 2.5), float(rng.choice([0.05, 0.1])))
    step = 0.25 * grid.resolution
    hits = []
    for _ in range(int(rng.integers(0, 8))):
        max_range = float(rng.uniform(0.3, 2.5))
        distance = float(rng.uniform(0, max_range))
        obs = RangeObservation(
            tuple(rng.uniform(-3.5, 3.5, 2)),
            float(rng.uniform(-7, 7)),
            float(rng.choice([0.0, math.radians(10), 1.0])),
            max_range,
            distance,
            True,
            float(rng.choice([0.0, 0.01, 0.05])),
        )
        hits.append((obs, distance))
    arcs = arc_cells(grid, hits, step)
    assert len(arcs) == len(hits)
    for (obs, distance), (cells, weights) in zip(hits, arcs, strict=True):
        points, likelihood = hit_points(obs, distance, step)
        flat, keep = grid.locate(points)
        expected, inverse = np.unique(flat[keep], return_inverse=True)
        summed = np.bincount(inverse, weights=likelihood[keep], minlength=expected.size)
        assert cells.tolist() == expected.tolist()
        assert weights.tolist() == summed.tolist()

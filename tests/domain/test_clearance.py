"""Clearance maps kept current by windowed updates equal a full distance transform."""

from __future__ import annotations

import numpy as np
import pytest

from domain.clearance import DistanceMap, clearance_map
from domain.grid import Grid
from domain.worldmodel import RangeObservation, WorldModel
from sim.world import Bounds


@pytest.mark.parametrize("seed", range(30))
def test_windowed_additions_equal_the_full_transform(seed: int) -> None:
    rng = np.random.default_rng(seed)
    grid = Grid(Bounds(-6, 6, -4, 5), 0.05)
    cap = float(rng.choice([0.3, 1.0, 2.0]))
    occupied = np.zeros(grid.shape, dtype=bool)
    occupied.flat[rng.integers(0, occupied.size, 5)] = True
    live = DistanceMap(grid, cap)
    live.get(occupied)  # a map to update from
    for _ in range(20):
        # a few cells, sometimes a clump, sometimes at the grid's edge
        cells = rng.integers(0, occupied.size, int(rng.integers(1, 6)))
        if rng.random() < 0.3:
            cells = np.append(cells, [0, occupied.size - 1])
        cells = cells[~occupied.flat[cells]]
        occupied.flat[cells] = True
        live.add(occupied, np.unique(cells))
        np.testing.assert_array_equal(live.get(occupied), clearance_map(occupied, 0.05, cap))


def test_removed_cells_need_a_reset() -> None:
    grid = Grid(Bounds(-1, 1, -1, 1), 0.05)
    occupied = np.zeros(grid.shape, dtype=bool)
    occupied[10, 10] = True
    live = DistanceMap(grid, 2.0)
    assert live.get(occupied)[10, 15] == pytest.approx(0.225)
    occupied[10, 10] = False
    live.reset()
    assert np.all(live.get(occupied) == 2.0)


def test_world_model_clearance_stays_that_of_its_layers() -> None:
    rng = np.random.default_rng(3)
    model = WorldModel(Bounds(-3, 3, -3, 3))
    targets = rng.uniform(-2, 2, (7, 2))
    static = WorldModel(Bounds(-3, 3, -3, 3)).clearance()  # walls only: what nothing sensed leaves
    for tick in range(120):
        readings = []
        for _ in range(6):
            # single rays at a few fixed targets: they become occupied; after tick 60 the
            # readings pass through them and they cease to be (the map is rebuilt then)
            target = targets[int(rng.integers(len(targets)))]
            origin = target + rng.uniform(-0.8, 0.8, 2)
            offset = target - origin
            d = float(np.hypot(*offset)) + (0.0 if tick < 60 else 0.3)  # then seen through
            angle = float(np.arctan2(offset[1], offset[0]))
            at = (float(origin[0]), float(origin[1]))
            readings.append(RangeObservation(at, angle, 0.0, 1.5, d, True, 0.02))
        model.integrate(readings)
        if tick % 25 == 0:
            model.add_contact((float(rng.uniform(-3, 3)), float(rng.uniform(-3, 3))))
        if tick % 10 == 0:
            layers = model.sensed_occupied() | model.contact_occupied()
            cap = model.settings.max_clearance
            full = clearance_map(layers, model.grid.resolution, cap)
            np.testing.assert_array_equal(model.clearance(), np.minimum(static, full))
    assert model.sensed_occupied().any() and model.contact_occupied().any()

"""Clearance maps kept current by windowed updates equal a full distance transform, and the
world model's lethal clearance stays that of its lethal layers (soft evidence never enters it)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from domain import kernels
from domain.world import Grid, RangeObservation, WorldModel
from domain.world.distance import DistanceMap, clearance_map
from sim.obstacles import Circle
from sim.world import Bounds


def random_layer(seed: int, cells: int) -> tuple[np.random.Generator, Grid, float, np.ndarray]:
    """A seeded generator, a 12 m x 9 m grid, a clearance cap and ``cells`` occupied cells."""
    rng = np.random.default_rng(seed)
    grid = Grid(Bounds(-6, 6, -4, 5), 0.05)
    cap = float(rng.choice([0.3, 1.0, 2.0]))
    occupied = np.zeros(grid.shape, dtype=bool)
    occupied.flat[rng.integers(0, occupied.size, cells)] = True
    return rng, grid, cap, occupied


@pytest.mark.parametrize("seed", range(30))
def test_windowed_additions_equal_the_full_transform(seed: int) -> None:
    rng, grid, cap, occupied = random_layer(seed, 5)
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


def ray_at(rng: np.random.Generator, targets: np.ndarray, seen_through: bool) -> RangeObservation:
    """A single ray from within 0.8 m of one of ``targets`` at it: hitting it, or reading
    0.3 m past it (it is seen through)."""
    target = targets[int(rng.integers(len(targets)))]
    origin = target + rng.uniform(-0.8, 0.8, 2)
    offset = target - origin
    d = float(np.hypot(*offset)) + (0.3 if seen_through else 0.0)
    angle = float(np.arctan2(offset[1], offset[0]))
    at = (float(origin[0]), float(origin[1]))
    return RangeObservation(at, angle, 0.0, 1.5, d, True, 0.02)


STRAIGHT = (0.0, 0.0, 0.0)


@pytest.mark.parametrize("seed", range(4))
def test_lethal_clearance_stays_that_of_its_layers(seed: int) -> None:
    """Readings that mark cells and later see through them, contacts, the body lying over
    cells, evidence cleared round the robot, a known obstacle added and removed: the lethal
    clearance read now and then is always the walls and known obstacles with a full transform
    of the sensed cells, and contact evidence never lowers it."""
    rng = np.random.default_rng(seed)
    bounds = Bounds(-3, 3, -3, 3)
    model = WorldModel(bounds)
    walls = WorldModel(bounds).static_clearance().copy()  # what nothing known or sensed leaves
    targets = rng.uniform(-2, 2, (7, 2))
    post = Circle(float(targets[0][0]), float(targets[0][1]), 0.2)
    contacts, counts = 0, []
    for tick in range(120):
        readings = [ray_at(rng, targets, seen_through=(tick // 30) % 2 == 1) for _ in range(6)]
        model.integrate(readings)
        counts.append(int(model.sensed_occupied().sum()))
        if tick % 20 == 7:
            x, y = (float(v) for v in rng.uniform(-2.5, 2.5, 2))
            lethal, version = model.lethal_clearance(), model.version
            model.add_contact((x, y, float(rng.uniform(-3, 3))), STRAIGHT, 2, "left", tick * 0.25)
            assert model.version == version and model.lethal_clearance() is lethal
            contacts += 1
        if tick % 25 == 11:
            x, y = (float(v) for v in targets[int(rng.integers(len(targets)))])
            model.observe_body((x - 0.2, y, 0.0), STRAIGHT)
        if tick % 40 == 30:
            model.clear_evidence((float(targets[1][0]), float(targets[1][1])), 0.5)
        if tick == 50:
            model.add_known(post)
        if tick == 90:
            assert model.remove_known(post)
        if tick % 10 == 0:
            static = model.static_clearance()
            cap = model.settings.max_clearance
            full = clearance_map(model.sensed_occupied(), model.grid.resolution, cap)
            np.testing.assert_array_equal(model.lethal_clearance(), np.minimum(static, full))
            if 50 <= tick < 90:
                assert np.all(static <= walls) and np.any(static < walls)
            else:
                np.testing.assert_array_equal(static, walls)
    rises = np.diff(counts)
    assert rises.max() > 0 and rises.min() < 0  # cells were marked, and cleared again
    assert contacts and model.soft_version > 0


@pytest.mark.parametrize("seed", range(20))
def test_windowed_removals_equal_the_full_transform(seed: int) -> None:
    rng, grid, cap, occupied = random_layer(seed, 40)
    other = np.zeros(grid.shape, dtype=bool)  # a second layer in the union
    other.flat[rng.integers(0, occupied.size, 10)] = True
    live = DistanceMap(grid, cap)
    live.get(occupied, other)
    for _ in range(20):
        gone = np.flatnonzero(occupied)
        gone = rng.choice(gone, min(gone.size, int(rng.integers(1, 4))), replace=False)
        occupied.flat[gone] = False
        live.remove((occupied, other), np.unique(gone))
        np.testing.assert_array_equal(live.get(), clearance_map(occupied | other, 0.05, cap))


@pytest.mark.parametrize("seed", range(12))
def test_windowed_removals_from_walls_equal_the_full_transform(seed: int) -> None:
    """Cells taken off the ends of thick walls, a few or a dozen at a time: many cells lose
    their nearest one (measured again by the transform over their window), or few do (one by
    one); either way the map is the full transform's."""
    rng, grid, cap, occupied = random_layer(seed, 20)
    cap = 2.0  # far reach: the cells beyond a wall's end all lose their nearest cell
    walls = []
    for _ in range(6):
        i, j = int(rng.integers(10, grid.nx - 40)), int(rng.integers(10, grid.ny - 40))
        length, across = int(rng.integers(10, 30)), bool(rng.random() < 0.5)
        cells = [
            (i + k, j + t) if across else (i + t, j + k) for k in range(length) for t in range(3)
        ]
        walls.append([a * grid.ny + b for a, b in cells])
        occupied.flat[walls[-1]] = True
    live = DistanceMap(grid, cap)
    live.get(occupied)
    for _ in range(25):
        wall = walls[int(rng.integers(len(walls)))]
        gone = [c for c in wall[: int(rng.integers(1, 13))] if occupied.flat[c]]
        del wall[: len(gone)]
        occupied.flat[gone] = False
        live.remove((occupied,), np.unique(np.asarray(gone, dtype=np.intp)))
        np.testing.assert_array_equal(live.get(), clearance_map(occupied, 0.05, cap))


@pytest.mark.parametrize("seed", range(40))
def test_compiled_transform_equals_scipys(seed: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """The compiled clearance map gives scipy's transform's numbers, value for value: sparse,
    dense, thin and one-cell grids, several resolutions and caps; so does the path taken with
    the kernels off."""
    if not kernels.AVAILABLE:
        pytest.skip("numba kernels are off")
    rng = np.random.default_rng(seed)
    for _ in range(40):
        nx, ny = (int(n) for n in rng.integers(1, 70, 2))
        occupied = rng.random((nx, ny)) < rng.choice([0.002, 0.02, 0.2, 0.6, 0.95])
        occupied.flat[int(rng.integers(occupied.size))] = True
        resolution, cap = float(rng.choice([0.03, 0.05, 0.1])), float(rng.choice([0.3, 2.0, 50.0]))
        scipy_map = np.clip(
            ndimage.distance_transform_edt(~occupied) * resolution - 0.5 * resolution, 0.0, cap
        )
        np.testing.assert_array_equal(clearance_map(occupied, resolution, cap), scipy_map)
        with monkeypatch.context() as m:
            m.setattr(kernels, "AVAILABLE", False)
            np.testing.assert_array_equal(clearance_map(occupied, resolution, cap), scipy_map)

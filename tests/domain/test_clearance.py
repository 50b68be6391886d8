"""Clearance maps kept current by windowed updates equal a full distance transform."""

from __future__ import annotations

import numpy as np
import pytest

from domain.clearance import DistanceMap, clearance_map
from domain.grid import Grid
from domain.interpolate import bilinear
from domain.worldmodel import RangeObservation, WorldModel
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
            readings.append(ray_at(rng, targets, seen_through=tick >= 60))
        model.integrate(readings)
        if tick % 25 == 0:
            model.add_contact((float(rng.uniform(-3, 3)), float(rng.uniform(-3, 3))))
        if tick % 10 == 0:
            layers = model.sensed_occupied() | model.contact_occupied()
            cap = model.settings.max_clearance
            full = clearance_map(layers, model.grid.resolution, cap)
            np.testing.assert_array_equal(model.clearance(), np.minimum(static, full))
    assert model.sensed_occupied().any() and model.contact_occupied().any()


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


def reference_inflated(model: WorldModel, inflation: float, grow: float, suspect: bool):
    """The inflated clearance grid from full transforms of the layers as they are now."""
    cap, res = model.settings.max_clearance, model.grid.resolution
    sensed = np.maximum(clearance_map(model.sensed_occupied(), res, cap) - inflation, 0.0)
    touched = model.contact_occupied() | (model.suspected() if suspect else False)
    near = np.maximum(clearance_map(touched, res, cap) - grow, 0.0)
    if grow == inflation and not suspect:
        dynamic = np.minimum(
            clearance_map(model.sensed_occupied(), res, cap),
            clearance_map(model.contact_occupied(), res, cap),
        )
        return np.minimum(model._static, np.maximum(dynamic - inflation, 0.0))
    return np.minimum(model._static, np.minimum(sensed, near))


@pytest.mark.parametrize("seed", range(6))
def test_inflated_clearance_kept_current_equals_a_rebuild(seed: int) -> None:
    """Readings that mark and unmark cells, contacts, suspected cells that beams clear again,
    a known obstacle: the inflated grids, read now and then, are always those of the layers."""
    rng = np.random.default_rng(seed)
    bounds = Bounds(-3, 3, -3, 3)
    model = WorldModel(bounds)
    targets = rng.uniform(-2, 2, (6, 2))
    centres = model.grid.centres(np.arange(model.grid.nx * model.grid.ny)).reshape(
        model.grid.nx, model.grid.ny, 2
    )
    keys = [(0.05, 0.1, True), (0.05, 0.05, False), (0.05, 0.02, False), (0.05, 0.1, False)]
    suspected_seen = False
    for tick in range(90):
        readings = []
        for _ in range(5):
            readings.append(ray_at(rng, targets, seen_through=(tick // 20) % 2 == 1))
        model.integrate(readings)
        if tick % 15 == 3:
            model.add_contact((float(rng.uniform(-2.5, 2.5)), float(rng.uniform(-2.5, 2.5))))
        if tick % 10 == 5:  # along a beam's line: later readings see some of them free
            target = targets[int(rng.integers(len(targets)))]
            line = target + np.linspace(-0.4, 0.4, 12)[:, None] * rng.normal(size=2)
            model.add_suspected([(float(x), float(y)) for x, y in line])
        if tick == 40:
            model.add_known(Circle(float(targets[0][0]), float(targets[0][1]), 0.2))
        suspected_seen |= bool(model.suspected().any())
        if tick % int(rng.integers(1, 6)) == 0:
            inflation, grow, suspect = keys[int(rng.integers(len(keys)))]
            got = model.inflated_clearance_at(centres, inflation, grow, suspected=suspect)
            want = reference_inflated(model, inflation, grow, suspect and model.suspected().any())
            np.testing.assert_array_equal(got, bilinear(want, model.grid, centres, bounds))
    assert suspected_seen and model.contact_occupied().any()


@pytest.mark.parametrize("seed", range(40))
def test_compiled_transform_equals_scipys(seed: int) -> None:
    """The compiled clearance map gives scipy's transform's numbers, value for value: sparse,
    dense, thin and one-cell grids, several resolutions and caps."""
    from scipy import ndimage

    from domain import occupancy_kernel

    if not occupancy_kernel.AVAILABLE:
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

"""The compiled sensed-layer update gives the numpy path's layer, value for value."""

from __future__ import annotations

import math

import numpy as np
import pytest

from domain import kernels
from domain.world import CostmapSettings, RangeObservation, WorldModel, bilinear
from domain.world.sensed import SensedLayer, clearing
from sim.obstacles import Circle, rectangle, unit_vectors
from sim.world import Bounds, World

pytestmark = pytest.mark.skipif(not kernels.AVAILABLE, reason="numba kernels are off")

BOUNDS = Bounds(-3.0, 3.0, -2.0, 2.0)
OBSTACLES = (
    Circle(1.0, 0.4, 0.3),
    rectangle(-1.2, -0.8, 0.6, 0.4),
    Circle(-0.5, 1.2, 0.2),
    rectangle(2.2, -1.0, 0.3, 1.0),
)
# (axis offset, fov, max range, noise σ): an IR cone, a wide cone, single rays, noisy or not
SENSORS = (
    (0.0, math.radians(10), 0.8, 0.0),
    (0.3, math.radians(40), 1.2, 0.03),
    *((k * math.pi / 4, 0.0, 1.5, 0.02 * (k % 2)) for k in range(8)),
)


def readings(
    world: World, rng: np.random.Generator, x: float, y: float, psi: float, sensors=SENSORS
):
    """Each sensor's nearest hit by ray casting the true world, noisy, sometimes dropped out."""
    out = []
    for offset, fov, reach, sigma in sensors:
        axis = psi + offset
        angles = axis + np.linspace(-fov / 2, fov / 2, 9 if fov else 1)
        dist, what = world.ray_cast(np.array([x, y]), unit_vectors(angles), reach)
        k = int(np.argmin(dist))
        hit = bool(what[k] != -2)
        value = float(dist[k])
        if hit and sigma:
            value = float(np.clip(value + rng.normal(0.0, sigma), 0.0, reach))
        if rng.random() < 0.05:
            value = math.nan  # a dropout
        out.append(RangeObservation((x, y), float(axis), fov, reach, value, hit, sigma))
    return out


# noisier sensors than the compiled layout's first likelihood table covers (σ 0.1, 0.2 m)
NOISY = (*SENSORS[:3], (1.0, math.radians(20), 1.5, 0.1), (-1.0, 0.0, 1.5, 0.2))


@pytest.mark.parametrize(
    ("seed", "sensors"), [(0, SENSORS), (1, SENSORS), (2, SENSORS), (0, NOISY)]
)
def test_compiled_update_equals_numpy(seed: int, sensors) -> None:
    """Along a random walk past obstacles (some known, some hidden), both layers hold the same
    log-odds bit for bit and report the same cells becoming and ceasing to be occupied, also
    when the body comes to lie over cells (``free``)."""
    rng = np.random.default_rng(seed)
    world = World(BOUNDS, OBSTACLES)
    model = WorldModel(BOUNDS, OBSTACLES[:2])  # its static layer explains hits on these
    known = model.static_clearance()
    settings = CostmapSettings()
    compiled = SensedLayer(model.grid, settings, compiled=True)
    reference = SensedLayer(model.grid, settings, compiled=False)
    assert compiled.compiled and not reference.compiled
    x, y, psi = -2.5, 0.0, 0.0
    changes = freed = 0
    marked = False
    for _ in range(300):
        psi += rng.normal(0.0, 0.3)
        x = float(np.clip(x + 0.05 * math.cos(psi), -2.8, 2.8))
        y = float(np.clip(y + 0.05 * math.sin(psi), -1.8, 1.8))
        obs = readings(world, rng, x, y, psi, sensors)
        became, ceased = compiled.integrate(obs, known)
        ref_became, ref_ceased = reference.integrate(obs, known)
        np.testing.assert_array_equal(became, ref_became)
        np.testing.assert_array_equal(ceased, ref_ceased)
        assert np.array_equal(compiled.log_odds, reference.log_odds)
        assert np.array_equal(compiled.occupied, reference.occupied)
        changes += became.size + ceased.size
        marked = marked or bool(compiled.occupied.any())
        if rng.random() < 0.2:  # the body comes to lie over a patch of cells: they are free
            some = rng.integers(0, model.grid.nx * model.grid.ny, 40)
            held = np.flatnonzero(reference.occupied)[:3]  # some of them occupied
            patch = np.unique(np.concatenate([some, held])).astype(np.intp)
            freed += int(reference.occupied.reshape(-1)[patch].sum())
            np.testing.assert_array_equal(compiled.free(patch), reference.free(patch))
            assert np.array_equal(compiled.log_odds, reference.log_odds)
            assert np.array_equal(compiled.occupied, reference.occupied)
    assert changes > 0 and freed > 0  # the walk did mark (and maybe unmark) cells
    assert np.any(compiled.log_odds < 0) and marked


def test_no_readings_change_nothing() -> None:
    model = WorldModel(BOUNDS)
    layer = SensedLayer(model.grid, CostmapSettings(), compiled=True)
    nan = RangeObservation((0.0, 0.0), 0.0, 0.0, 1.0, math.nan, False)
    became, ceased = layer.integrate([nan], model.static_clearance())
    assert became.size == 0 and ceased.size == 0
    assert not np.any(layer.log_odds)


def test_pairwise_sum_is_numpys() -> None:
    """The kernels normalise evidence with numpy's summation order, not a plain loop's."""
    rng = np.random.default_rng(3)
    for n in (*range(0, 20), 127, 128, 129, 300, 1000):
        a = rng.random(n) * 10.0 ** rng.integers(-3, 3, n)
        assert clearing._pairwise_sum(a, 0, n) == np.sum(a)


@pytest.mark.parametrize("shape", [(1, 1), (1, 7), (6, 1), (40, 30)])
def test_bilinear_equals_numpy(shape: tuple[int, int], monkeypatch: pytest.MonkeyPatch) -> None:
    """The compiled interpolation gives numpy's values, inside, on and beyond the outer centres."""
    rng = np.random.default_rng(4)
    nx, ny = shape
    bounds = Bounds(-1.0, -1.0 + nx * 0.05, 2.0, 2.0 + ny * 0.05)
    model = WorldModel(bounds)
    grid = rng.random(shape) * 2.0
    pts = np.stack(
        [
            rng.uniform(-1.3, bounds.xmax + 0.3, (5, 41)),
            rng.uniform(1.7, bounds.ymax + 0.3, (5, 41)),
        ],
        axis=-1,
    )
    compiled = bilinear(grid, model.grid, pts)
    within = bilinear(grid, model.grid, pts, bounds)
    monkeypatch.setattr(kernels, "AVAILABLE", False)
    reference = bilinear(grid, model.grid, pts)
    assert compiled.shape == reference.shape == within.shape == (5, 41)
    assert np.array_equal(compiled, reference)
    assert np.array_equal(within, bilinear(grid, model.grid, pts, bounds))
    assert np.any(within < 0) and np.any(within < compiled)  # points outside, near the walls

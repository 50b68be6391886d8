"""The suspected tier's grid, kept current by windows, equals one built afresh for each version."""

from __future__ import annotations

import math

import numpy as np
import pytest

from domain import occupancy_kernel
from domain.clearance import clearance_map
from domain.interpolate import bilinear
from domain.worldmodel import RangeObservation, WorldModel, WorldModelSettings
from sim.world import Bounds

KEYS = ((0.05, 0.1), (0.05, 0.02))  # the tiers' (sensed, contact) inflations


def reading(rng: np.random.Generator, targets: np.ndarray, tick: int) -> RangeObservation:
    """A reading near one of ``targets``: a single ray at it (hitting it, or, every other
    stretch of ticks, seeing 0.3 m past it), or a narrow cone past it that observes the cells
    beside it (the continuation shrinks)."""
    target = targets[int(rng.integers(len(targets)))]
    origin = target + rng.uniform(-0.9, 0.9, 2)
    offset = target - origin
    angle = float(np.arctan2(offset[1], offset[0]))
    d = float(np.hypot(*offset))
    at = (float(origin[0]), float(origin[1]))
    kind = rng.random()
    if kind < 0.25:  # a cone grazing the target: it clears cells beside it
        return RangeObservation(at, angle + float(rng.normal(0, 0.2)), 0.3, 1.2, 1.2, False, 0.02)
    through = (tick // 15) % 2 == 1 and kind < 0.6
    return RangeObservation(at, angle, 0.0, 1.5, d + (0.3 if through else 0.0), True, 0.02)


def fresh(model: WorldModel, inflation: float, grow: float) -> np.ndarray:
    """The suspected tier's grid built from the layers as they are now: the contacts, the
    suspected surfaces and the never-observed cells within reach of a sensed cell marked."""
    cap, res = model.settings.max_clearance, model.grid.resolution
    sensed_map = clearance_map(model.sensed_occupied(), res, cap)
    continuation = (sensed_map <= model.settings.sensed_continuation) & (model.log_odds == 0.0)
    if not model.sensed_occupied().any():
        continuation[:] = False
    marked = model.contact_occupied() | model._marked.suspected | continuation
    sensed = np.maximum(sensed_map - inflation, 0.0)
    near = np.maximum(clearance_map(marked, res, cap) - grow, 0.0)
    return np.minimum(model._static, np.minimum(sensed, near))


@pytest.mark.parametrize("seed", range(8))
def test_suspected_tier_kept_current_equals_a_fresh_build(seed: int) -> None:
    """Readings that mark cells and observe the cells around them, readings that see through
    them, contacts, suspected surfaces: read on every tick, the suspected tier's grid is the one
    built afresh from the layers when the model's version changed (its marked cells are taken
    once per version)."""
    rng = np.random.default_rng(seed)
    bounds = Bounds(-3, 3, -2.5, 2.5)
    model = WorldModel(bounds, settings=WorldModelSettings(sensed_continuation=0.25))
    targets = rng.uniform(-2, 2, (5, 2))
    centres = model.grid.centres(np.arange(model.grid.nx * model.grid.ny))
    want: dict[tuple[float, float], np.ndarray] = {}
    version, changes = -1, 0
    for tick in range(70):
        model.integrate([reading(rng, targets, tick) for _ in range(int(rng.integers(1, 6)))])
        if tick % 17 == 9:
            target = targets[int(rng.integers(len(targets)))]
            model.add_contact((float(target[0]) + 0.1, float(target[1])))
        if tick % 11 == 4:
            target = targets[int(rng.integers(len(targets)))]
            line = target + np.linspace(-0.3, 0.3, 8)[:, None] * rng.normal(size=2)
            model.add_suspected([(float(x), float(y)) for x, y in line])
        if model.version != version:  # the marked cells are taken now, once per version
            version, changes = model.version, changes + 1
            want = {key: fresh(model, *key) for key in KEYS}
        for key in KEYS:
            got = model.inflated_clearance_at(centres, *key, suspected=True)
            np.testing.assert_array_equal(got, bilinear(want[key], model.grid, centres, bounds))
    assert changes > 20 and model.any_suspected() and model.contact_occupied().any()


def test_the_continuation_follows_the_readings() -> None:
    """A hidden wall seen in part: the never-observed cells beyond its end are suspected until
    a beam sees them free (taken when the model's version next changes); the sensed cells seen
    through leave no continuation behind."""
    model = WorldModel(Bounds(-2.0, 2.0, -1.0, 1.0))
    wall = [RangeObservation((x, 0.0), math.pi / 2, 0.0, 1.0, 0.5, True, 0.02) for x in (-0.2, 0.0)]
    for _ in range(3):
        model.integrate(wall)
    cell = model.cell_of(0.15, 0.5)  # past the seen end of the wall, never observed
    beyond = np.array([model.centre_of(*cell)])
    assert model.any_suspected() and model.suspected()[cell]
    assert model.inflated_clearance_at(beyond, 0.05, 0.1, suspected=True)[0] == 0.0
    seen = RangeObservation((0.15, 0.0), math.pi / 2, 0.0, 1.0, 1.0, False, 0.02)
    model.integrate([seen])  # a beam sees the cells there free ...
    model.add_contact((-1.5, -0.5))  # ... taken at the next version of the model
    assert not model.suspected()[cell]
    assert model.inflated_clearance_at(beyond, 0.05, 0.02, suspected=True)[0] > 0.0
    through = [
        RangeObservation((x, 0.0), math.pi / 2, 0.0, 1.0, 1.0, False, 0.02) for x in (-0.2, 0.0)
    ]
    for _ in range(6):
        model.integrate(through)  # the wall ceases: a new version each time
    assert not model.sensed_occupied().any() and not model.any_suspected()
    assert model.inflated_clearance_at(beyond, 0.05, 0.1, suspected=True)[0] > 0.3


def test_without_kernels_the_same_grid(monkeypatch: pytest.MonkeyPatch) -> None:
    """The numpy path marks the same cells as the compiled one."""
    if not occupancy_kernel.AVAILABLE:
        pytest.skip("numba kernels are off")
    grids = []
    for available in (True, False):
        monkeypatch.setattr(occupancy_kernel, "AVAILABLE", available)
        rng = np.random.default_rng(5)
        model = WorldModel(Bounds(-3, 3, -2.5, 2.5))
        targets = rng.uniform(-2, 2, (4, 2))
        centres = model.grid.centres(np.arange(model.grid.nx * model.grid.ny))
        for tick in range(30):
            model.integrate([reading(rng, targets, tick) for _ in range(3)])
            model.inflated_clearance_at(centres, 0.05, 0.1, suspected=True)
        grids.append(model.inflated_clearance_at(centres, 0.05, 0.1, suspected=True))
    np.testing.assert_array_equal(grids[0], grids[1])

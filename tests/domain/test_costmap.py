"""The costmap: exact static clearance, a sensed layer without phantoms, observed cells, soft
contact evidence, the lethal and risk views, versions."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy import ndimage

from domain.world import CostmapSettings, RangeObservation, WorldModel, range_observations, static
from domain.world.contact import touched_side
from sim.obstacles import Circle, Obstacle, Polygon, point_segment_distance, rectangle, unit_vectors
from sim.robot import head_tip
from sim.sensors import SensorSuite, forward_ir, range_ring
from sim.world import Bounds, World

SIGMA = 0.02
IR_FOV = math.radians(10)
RES = CostmapSettings().resolution
# A 0.30 m corridor along x (inner faces at y = ±0.15) whose walls reach the arena's ends.
CORRIDOR = (rectangle(0.0, 0.25, 4.0, 0.2), rectangle(0.0, -0.25, 4.0, 0.2))


def sensor_layout(heading: float) -> list[tuple[float, float, float, int]]:
    """The project's layout: forward IR (10° cone, 0.8 m) and a ring of 8 rays (1.0 m, 45°).
    Rows: axis angle, fov, max range, rays used to find the cone's nearest hit."""
    ir = [(heading, IR_FOV, 0.8, 21)]
    return ir + [(heading + k * math.pi / 4, 0.0, 1.0, 1) for k in range(8)]


def observe(
    world: World,
    origin: tuple[float, float],
    heading: float,
    rng: np.random.Generator,
    ir_only: bool = False,
) -> list[RangeObservation]:
    """Readings by ray casting the true world: each sensor's nearest hit, noisy when it hit."""
    out = []
    layout = sensor_layout(heading)[: 1 if ir_only else None]
    for axis, fov, reach, rays in layout:
        angles = axis + np.linspace(-fov / 2, fov / 2, rays)
        dist, what = world.ray_cast(np.asarray(origin), unit_vectors(angles), reach)
        k = int(np.argmin(dist))
        hit = bool(what[k] != -2)
        value = float(dist[k])
        if hit:
            value = float(np.clip(value + rng.normal(0.0, SIGMA), 0.0, reach))
        out.append(RangeObservation(origin, float(axis), fov, reach, value, hit, SIGMA))
    return out


def surface_distance(world: World, points: np.ndarray) -> np.ndarray:
    """Unsigned distance from points [N, 2] to the nearest true obstacle surface or wall."""
    best = np.abs(world.bounds.wall_clearance(points))
    for obstacle in world.obstacles:
        if isinstance(obstacle, Circle):
            d = np.abs(np.linalg.norm(points - obstacle.centre, axis=-1) - obstacle.radius)
        else:
            ea, eb = obstacle.edges
            d = point_segment_distance(points[:, None, :], ea, eb).min(axis=-1)
        best = np.minimum(best, d)
    return best


def exact_clearance(bounds: Bounds, obstacles: tuple[Obstacle, ...], points: np.ndarray):
    """The oracle: sim's own geometry (a zero-length segment is a point), min with the walls."""
    best = bounds.wall_clearance(points)
    for obstacle in obstacles:
        best = np.minimum(best, obstacle.segment_clearance(points, points))
    return best


def all_centres(model: WorldModel) -> np.ndarray:
    x, y = np.meshgrid(model.grid.xs, model.grid.ys, indexing="ij")
    return np.stack([x, y], axis=-1)


def sensed_centres(model: WorldModel) -> np.ndarray:
    return model.grid.centres(np.flatnonzero(model.sensed_occupied()))


def ray(origin, angle, distance, hit=True, fov=0.0, max_range=1.0, noise=0.0):
    return RangeObservation(origin, angle, fov, max_range, distance, hit, noise)


def connected(model: WorldModel, a: tuple[float, float], b: tuple[float, float], need: float):
    """Whether cells of lethal clearance >= ``need`` join the cells holding ``a`` and ``b``."""
    labels, _ = ndimage.label(model.lethal_clearance() >= need)
    ia, ib = model.cell_of(*a), model.cell_of(*b)
    inside = all(model.grid.inside(*c) for c in (ia, ib))
    return bool(inside and labels[ia] != 0 and labels[ia] == labels[ib])


def axis_clear(model: WorldModel, points: np.ndarray, need: float) -> bool:
    """Whether every point keeps ``need`` from what is lethal."""
    return bool(np.all(model.clearance_at(points) >= need))


# --- static layer ---------------------------------------------------------------------------


def test_static_clearance_is_exact_at_cell_centres():
    bounds = Bounds(-2.0, 2.0, -1.5, 1.5)
    known = (
        Circle(0.7, 0.4, 0.25),
        rectangle(-0.8, -0.3, 0.6, 0.2, 0.6),
        Polygon(((0.2, -1.0), (0.9, -0.8), (0.4, -0.3))),
    )
    model = WorldModel(bounds, known)
    centres = all_centres(model)
    cap = model.settings.max_clearance
    expected = np.clip(exact_clearance(bounds, known, centres), 0.0, cap)
    np.testing.assert_allclose(model.lethal_clearance(), expected, atol=1e-12)
    # Occupied: known obstacles within half a cell of the centre (a thin wall is not lost).
    assert np.array_equal(
        model.occupied(), exact_clearance(Bounds(-9, 9, -9, 9), known, centres) < RES / 2 - 1e-9
    )


@pytest.mark.parametrize("seed", range(3))
def test_a_polygons_distances_compiled_are_its_numpy_paths(seed: int, monkeypatch):
    """The static layer's distances to a polygon, convex or not, tilted or not, are the same
    floats from the compiled call and from numpy (each the sim's geometry to 1e-12)."""
    rng = np.random.default_rng(seed)
    xs = np.sort(rng.uniform(-3.0, 3.0, 47))
    ys = np.sort(rng.uniform(-3.0, 3.0, 31))
    for n in (3, 4, 7, 11):
        angles = np.sort(rng.uniform(0.0, 2 * np.pi, n))
        radii = rng.uniform(0.2, 2.0, n)  # uneven radii: most of these are not convex
        vertices = np.stack([radii * np.cos(angles), radii * np.sin(angles)], axis=-1)
        polygon = Polygon(tuple(map(tuple, vertices + rng.uniform(-1, 1, 2))))
        ea, eb = (np.ascontiguousarray(e, dtype=float) for e in polygon.edges)
        got = static.polygon_distances(xs, ys, ea, eb)
        with monkeypatch.context() as m:
            m.setattr(static, "AVAILABLE", False)
            want = static.polygon_distances(xs, ys, ea, eb)
        assert np.array_equal(got, want)
        points = np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1).reshape(-1, 2)
        exact = polygon.segment_clearance(points, points).reshape(got.shape)
        np.testing.assert_allclose(got, exact, atol=1e-12)
        assert (got == 0).any() and (got > 0).any()


@pytest.mark.parametrize("shift", [0.0, 0.01, 0.025, 0.037])
def test_known_corridor_is_exactly_030_wide_and_the_robot_fits(shift):
    bounds = Bounds(-2.0, 2.0, -1.0 + shift, 1.0 + shift)  # every alignment of cells to the walls
    model = WorldModel(bounds, CORRIDOR)
    inside = np.abs(model.grid.ys) < 0.15
    np.testing.assert_allclose(
        model.lethal_clearance()[40, inside], 0.15 - np.abs(model.grid.ys[inside])
    )
    # The robot is 0.15 m wide: straight along the axis it keeps 0.075 m from each wall.
    axis = np.stack([np.linspace(-1.0, 0.9, 40), np.zeros(40)], axis=-1)
    # Between centres the bilinear reading of the distance cone errs low, by at most half a cell.
    assert np.all(model.clearance_at(axis) >= 0.15 - RES / 2 - 1e-9)
    assert axis_clear(model, axis, 0.075)
    assert connected(model, (-1.8, 0.0), (1.8, 0.0), 0.075)
    assert not connected(model, (-1.8, 0.0), (1.8, 0.0), 0.16)


def test_add_known_updates_static_layer_and_version():
    model = WorldModel(Bounds(-1, 1, -1, 1))
    before = model.version
    model.add_known(Circle(0.0, 0.0, 0.2))
    assert model.version == before + 1
    assert model.lethal_clearance()[model.cell_of(0.5, 0.0)] == pytest.approx(
        math.hypot(0.525, 0.025) - 0.2
    )
    assert model.clearance_at(np.array([0.5, 0.0])) == pytest.approx(0.3, abs=1e-3)
    model.add_known(Circle(0.0, 0.0, 0.1))  # inside the first: nothing changes
    model.add_known(Circle(30.0, 0.0, 0.1))  # far outside the grid
    assert model.version == before + 1
    assert len(model.known) == 3
    assert model.remove_known(Circle(0.0, 0.0, 0.2)) and model.version == before + 2
    assert not model.remove_known(Circle(0.0, 0.0, 0.2))
    assert model.clearance_at(np.array([0.5, 0.0])) == pytest.approx(0.4, abs=1e-3)
    assert WorldModel(Bounds(-1, 1, -1, 1), (Circle(0.0, 0.0, 0.2),)).version == 0


# --- sensed layer ---------------------------------------------------------------------------


def phantom_arena() -> World:
    obstacles = (
        Circle(0.0, 0.0, 0.3, known=False),
        rectangle(1.5, 0.0, 0.1, 1.2),
        rectangle(-1.2, 1.2, 0.4, 0.2, 0.5),
        Polygon(((-1.0, -1.3), (-0.6, -1.5), (-0.8, -1.0))),
    )
    return World(Bounds(-2, 2, -2, 2), obstacles)


def drive(model: WorldModel, world: World, seconds: float = 60.0, seed: int = 0) -> int:
    """The head circles the arena, swinging its heading, read at 4 Hz; returns version bumps."""
    rng = np.random.default_rng(seed)
    bumps, version = 0, model.version
    for k in range(int(seconds * 4)):
        t = k / 4
        a = 0.1 * t
        heading = a + math.pi / 2 + 0.8 * math.sin(0.5 * t)
        model.integrate(observe(world, (math.cos(a), math.sin(a)), heading, rng))
        bumps += model.version != version
        version = model.version
    return bumps


@pytest.mark.parametrize("seed", [0, 1])
def test_noise_leaves_no_persistent_phantoms_and_real_obstacles_are_marked(seed):
    world = phantom_arena()
    model = WorldModel(world.bounds)  # nothing known: every obstacle is sensed
    drive(model, world, seed=seed)
    centres = sensed_centres(model)
    assert len(centres) > 30
    assert surface_distance(world, centres).max() <= 2 * SIGMA + RES
    # The hidden circle, seen over and over, is occupied near its surface.
    ring = np.abs(np.linalg.norm(centres, axis=-1) - 0.3) <= 2 * SIGMA + RES
    assert ring.sum() >= 20
    assert model.clearance_at(np.array([0.0, 0.33])) < 0.05


def test_cone_straddling_a_corridor_does_not_block_it():
    world = World(Bounds(-2.0, 2.0, -1.0, 1.0), CORRIDOR)
    for y0, degrees in [(0.0, 12), (0.0, 20), (0.04, 8), (-0.06, 24), (-0.03, 16), (0.0, 40)]:
        model = WorldModel(world.bounds)
        rng = np.random.default_rng(degrees)
        for _ in range(80):  # staring: the same ambiguous arc, over and over
            model.integrate(observe(world, (-0.5, y0), math.radians(degrees), rng, ir_only=True))
        centres = sensed_centres(model)
        assert not np.any(np.abs(centres[:, 1]) < 0.08), (y0, degrees, centres)
        assert connected(model, (-1.9, 0.0), (1.9, 0.0), 0.07)
        assert model.log_odds.max() <= model.settings.log_odds_max


def test_driving_down_an_unknown_corridor_keeps_it_passable():
    world = World(Bounds(-2.0, 2.0, -1.0, 1.0), CORRIDOR)
    model = WorldModel(world.bounds)
    rng = np.random.default_rng(1)
    for k in range(240):
        t = k / 4
        origin = (-1.3 + 0.01 * t, 0.03 * math.sin(0.7 * t))
        model.integrate(observe(world, origin, 0.35 * math.sin(0.4 * t), rng))
    centres = sensed_centres(model)
    assert len(centres) > 20  # the walls were seen
    assert not np.any(np.abs(centres[:, 1]) < 0.08)
    xs = np.linspace(-1.3, 1.3, 40)
    axis = np.stack([xs, np.zeros_like(xs)], axis=-1)
    assert axis_clear(model, axis, 0.07)
    assert connected(model, (-1.9, 0.0), (1.9, 0.0), 0.07)


def test_hits_on_known_geometry_leave_the_sensed_layer_alone():
    world = World(Bounds(-2.0, 2.0, -1.0, 1.0), CORRIDOR)
    model = WorldModel(world.bounds, CORRIDOR)
    rng = np.random.default_rng(4)
    for k in range(120):
        model.integrate(observe(world, (-1.0 + 0.01 * k, 0.0), 0.3 * math.sin(k / 5), rng))
    assert not model.sensed_occupied().any()
    assert model.version == 0  # construction is no change; nothing since


def test_ray_clearing_removes_an_obstacle_that_left():
    bounds = Bounds(-1.0, 1.0, -1.0, 1.0)
    model = WorldModel(bounds)
    became = []
    for _ in range(3):
        became += model.integrate([ray((0.0, 0.0), 0.0, 0.5)])
    assert became == [model.centre_of(*model.cell_of(0.5, 0.0))]
    assert model.sensed_occupied()[model.cell_of(0.5, 0.0)]
    assert model.integrate([ray((0.0, 0.0), 0.0, 0.5)]) == []  # already occupied: not new
    version = model.version
    for _ in range(10):  # the obstacle is gone: "nothing within range"
        model.integrate([ray((0.0, 0.0), 0.0, 1.0, hit=False)])
    assert not model.sensed_occupied().any()
    assert model.version == version + 1
    assert model.log_odds.min() >= model.settings.log_odds_min


def test_a_wide_cone_reading_nothing_clears_its_whole_sector():
    model = WorldModel(Bounds(-1.0, 1.0, -1.0, 1.0))
    model.integrate([ray((0.0, 0.0), 0.0, 0.8, hit=False, fov=math.radians(40), max_range=0.8)])
    cleared = model.log_odds < 0
    assert cleared[model.cell_of(0.6, 0.2)] and cleared[model.cell_of(0.6, -0.2)]
    assert not cleared[model.cell_of(0.6, 0.3)] and not cleared[model.cell_of(-0.2, 0.0)]
    assert not cleared[model.cell_of(0.85, 0.0)]


def test_single_cone_hit_is_spread_thinly_over_its_arc():
    model = WorldModel(Bounds(-1.0, 1.0, -1.0, 1.0))
    model.integrate([ray((0.0, 0.0), 0.0, 0.7, fov=IR_FOV, max_range=0.8, noise=SIGMA)])
    raised = model.log_odds[model.log_odds > 0]
    assert raised.size >= 3
    assert raised.max() < model.settings.log_odds_hit / 2
    assert raised.sum() == pytest.approx(model.settings.log_odds_hit)


def test_dropout_changes_nothing():
    model = WorldModel(Bounds(-1.0, 1.0, -1.0, 1.0))
    assert model.integrate([ray((0.0, 0.0), 0.0, math.nan)]) == []
    assert model.version == 0 and not model.log_odds.any()


def test_version_is_stable_when_nothing_changes():
    world = World(Bounds(-1.0, 1.0, -1.0, 1.0))
    model = WorldModel(world.bounds)
    rng = np.random.default_rng(5)
    clearance = model.lethal_clearance()
    for k in range(40):  # an empty arena: wall hits are the walls', open space stays free
        model.integrate(observe(world, (0.3 * math.cos(k / 7), 0.0), k / 3, rng))
    assert model.version == 0
    assert model.lethal_clearance() is clearance  # cached


# --- contact, clearance, queries --------------------------------------------------------------


def test_clearance_is_a_conservative_distance_transform_combined_with_walls():
    model = WorldModel(Bounds(-1.0, 1.0, -1.0, 1.0))
    for _ in range(3):  # one sensed cell
        model.integrate([ray((-0.5, 0.025), 0.0, 0.525)])
    clearance = model.lethal_clearance()
    i, j = model.cell_of(0.025, 0.025)
    assert model.sensed_occupied()[i, j] and model.sensed_occupied().sum() == 1
    assert clearance[i + 4, j] == pytest.approx(4 * RES - RES / 2)
    assert clearance[i + 3, j + 4] == pytest.approx(5 * RES - RES / 2)
    assert clearance[0, j] == pytest.approx(RES / 2)  # the wall is nearer
    # Between centres: bilinear; outside the bounds: negative.
    assert model.clearance_at(np.array([0.25, 0.025])) == pytest.approx(0.2)
    assert model.clearance_at(np.array([[1.1, 0.0], [0.0, -1.05]])).max() < 0
    assert clearance[i, j] == 0.0


def test_a_wall_with_a_gap_is_connected_through_the_gap_only_if_wide_enough():
    wall_with_gap = (rectangle(0.0, 0.65, 0.1, 0.7), rectangle(0.0, -0.45, 0.1, 1.1))  # y 0.1-0.3
    model = WorldModel(Bounds(-1.0, 1.0, -1.0, 1.0), wall_with_gap)
    assert connected(model, (-0.5, 0.0), (0.5, 0.0), 0.07)
    assert not connected(model, (-0.5, 0.0), (0.5, 0.0), 0.08)
    assert not connected(model, (-0.5, 0.0), (5.0, 0.0), 0.0)  # outside the grid


# --- contact evidence -----------------------------------------------------------------------


POSE = (0.0, 0.0, 0.0)  # the straight body lies along +x from the origin; the head faces -x
STRAIGHT = (0.0, 0.0, 0.0)


def test_a_side_contact_is_evidence_along_the_touched_side_never_lethal():
    model = WorldModel(Bounds(-2.0, 2.0, -2.0, 2.0))
    lethal, version = model.lethal_clearance(), model.version
    points = model.add_contact(POSE, STRAIGHT, 4, "left", 1.0)
    # unit 4 spans x 0.68-0.9 on the axis; its left (looking to the head, -x) is -y
    assert np.all(np.abs(points[:, 1] + 0.075 + 0.02) < 1e-9)
    assert points[:, 0].min() < 0.68 and points[:, 0].max() > 0.9
    assert model.version == version and model.lethal_clearance() is lethal  # soft: not lethal
    evidence = model.evidence()
    touched = evidence > 0
    assert touched.sum() >= 5
    # one contact is about one obstacle somewhere along the side: shared by its cells
    assert -np.log1p(-evidence[touched]).sum() == pytest.approx(
        -math.log1p(-model.settings.contact_probability / touched.sum()) * touched.sum()
    )
    assert model.risk()[touched].max() < 0.0
    data = model.to_dict()
    assert len(data["contact"]) == touched.sum() and len(data["evidence"]) == touched.sum()


def test_repeated_contacts_add_up_and_beams_narrow_them_down():
    model = WorldModel(Bounds(-2.0, 2.0, -2.0, 2.0))
    model.add_contact(POSE, STRAIGHT, 4, "rear", 1.0)  # round the tail's end
    once = model.evidence().max()
    model.add_contact(POSE, STRAIGHT, 4, "rear", 2.0)
    assert model.evidence().max() > once
    cells = np.argwhere(model.evidence() > 0)
    # A beam along the axis past the tail sees the middle cells free: what was touched is in
    # the others, more likely than before.
    before = model.evidence().copy()
    for _ in range(2):
        model.integrate([ray((-0.055, 0.0), 0.0, 1.5, hit=False, max_range=1.5)])
    after = model.evidence()
    cleared = [tuple(c) for c in cells if after[tuple(c)] == 0]
    kept = [tuple(c) for c in cells if after[tuple(c)] > 0]
    assert cleared and kept
    assert all(after[c] > before[c] for c in kept)
    # Seen free everywhere (the body lying over the middle, beams fanning past the sides), the
    # contact is gone.
    model.observe_body((0.6, 0.0, 0.0), STRAIGHT)
    for _ in range(2):
        model.integrate(
            [ray((0.3, 0.0), a, 1.5, hit=False, max_range=1.5) for a in np.linspace(-0.6, 0.6, 25)]
        )
    assert not model.evidence().any()


def test_contact_evidence_fades_with_its_half_life():
    settings = CostmapSettings(contact_half_life=100.0)
    model = WorldModel(Bounds(-2.0, 2.0, -2.0, 2.0), settings=settings)
    model.add_contact(POSE, STRAIGHT, 2, "right", 0.0)
    fresh = model.evidence().max()
    model.advance(100.0)
    assert model.evidence().max() == pytest.approx(fresh / 2, rel=0.05)
    model.advance(2000.0)
    assert not model.evidence().any()


def test_an_end_contact_lies_round_the_end_and_the_sides_are_checked():
    settings = CostmapSettings()
    points = touched_side(POSE, STRAIGHT, 0, "front", settings)
    # round the head's rounded end, ahead of it (the head leads along -x)
    assert np.all(np.hypot(points[:, 0] + 0.055, points[:, 1]) == pytest.approx(0.07))
    assert points[:, 0].max() < -0.055 + 1e-9
    with pytest.raises(ValueError, match="side"):
        touched_side(POSE, STRAIGHT, 1, "top", settings)
    with pytest.raises(ValueError, match="part"):
        touched_side(POSE, STRAIGHT, 5, "left", settings)


# --- observed cells and the risk view --------------------------------------------------------


def test_beams_and_the_body_observe_cells_and_the_risk_is_the_prior_where_unobserved():
    settings = CostmapSettings()
    model = WorldModel(Bounds(-2.0, 2.0, -2.0, 2.0), settings=settings)
    prior = settings.unobserved_log_free
    assert prior == pytest.approx(-settings.unobserved_density * RES**2)
    risk = model.risk()
    assert risk[model.cell_of(0.5, 0.5)] == pytest.approx(prior)
    assert risk[model.cell_of(1.9, 1.9)] == pytest.approx(prior)  # far away too
    soft = model.soft_version
    model.integrate([ray((0.0, 0.0), 0.0, 0.9, hit=False, max_range=0.9)])
    assert model.soft_version > soft and model.version == 0
    seen = model.observed()
    assert seen[model.cell_of(0.5, 0.0)] and not seen[model.cell_of(0.5, 0.5)]
    assert model.risk()[model.cell_of(0.5, 0.0)] == 0.0
    model.observe_body((0.0, -0.5, 0.0), STRAIGHT)
    assert model.observed()[model.cell_of(0.45, -0.5)]
    assert model.to_dict()["observed_fraction"] > 0


def test_never_observed_space_beyond_the_horizon_carries_a_share_of_the_prior():
    """Priced from where the robot is, never-observed space within the horizon keeps the whole
    prior and farther space the share; observed cells and contact evidence risk the same."""
    model = WorldModel(Bounds(-3.0, 3.0, -3.0, 3.0))
    prior = model.settings.unobserved_log_free
    model.integrate([ray((0.0, 0.0), 0.0, 2.5, hit=False, max_range=2.5)])
    risk = model.risk((0.0, 0.0), 1.0, 0.25)
    assert risk[model.cell_of(0.0, 0.8)] == pytest.approx(prior)  # within the horizon
    assert risk[model.cell_of(0.0, 1.5)] == pytest.approx(0.25 * prior)  # beyond it
    assert risk[model.cell_of(2.0, 0.0)] == 0.0  # a beam crossed it, far or not
    moved = model.risk((0.0, 1.5), 1.0, 0.25)  # the robot came closer
    assert moved[model.cell_of(0.0, 1.5)] == pytest.approx(prior)
    assert np.array_equal(model.risk(), model.risk((0.0, 0.0), 1.0, 1.0))  # share 1: whole


def test_never_observed_space_ahead_of_the_head_carries_the_share_however_near():
    """The body reaches what lies ahead of its head head first, after the head's rays swept
    it: within the horizon, only the space behind the head's tip (beside and behind the
    body, where a turn or a tail-first move sweeps unseen) keeps the whole prior."""
    model = WorldModel(Bounds(-3.0, 3.0, -3.0, 3.0))
    prior = model.settings.unobserved_log_free
    looking_east = model.risk((0.0, 0.0), 1.0, 0.25, facing=(0.1, 0.0, 0.0))
    assert looking_east[model.cell_of(0.6, 0.3)] == pytest.approx(0.25 * prior)  # ahead
    assert looking_east[model.cell_of(-0.6, 0.3)] == pytest.approx(prior)  # behind the tip
    assert looking_east[model.cell_of(0.0, 0.8)] == pytest.approx(prior)  # beside the body
    assert looking_east[model.cell_of(-1.5, 0.0)] == pytest.approx(0.25 * prior)  # far
    looking_west = model.risk((0.0, 0.0), 1.0, 0.25, facing=(-0.1, 0.0, math.pi))
    assert looking_west[model.cell_of(0.6, 0.3)] == pytest.approx(prior)  # now behind
    assert looking_west[model.cell_of(-0.6, 0.3)] == pytest.approx(0.25 * prior)


def test_the_body_lying_over_sensed_cells_frees_them():
    model = WorldModel(Bounds(-2.0, 2.0, -2.0, 2.0))
    for _ in range(3):  # a phantom on the body's axis
        model.integrate([ray((-0.5, 0.025), 0.0, 0.975)])
    assert model.sensed_occupied()[model.cell_of(0.475, 0.025)]
    version = model.version
    model.observe_body((0.0, 0.025, 0.0), STRAIGHT)
    assert not model.sensed_occupied().any() and model.version == version + 1


def test_never_observed_cells_next_to_a_sensed_surface_may_block_the_way():
    model = WorldModel(Bounds(-2.0, 2.0, -1.0, 1.0))
    for _ in range(3):  # a hidden wall along y = 0.5, seen from below between x = -1.5 and -0.8
        model.integrate([ray((x, 0.0), math.pi / 2, 0.5) for x in np.arange(-1.5, -0.79, 0.05)])
        model.integrate([ray((-1.5, 0.0), 0.0, 1.0, hit=False)])  # free along y = 0
    blocked = model.blocked()
    assert model.sensed_occupied()[model.cell_of(-1.0, 0.5)]
    # Where the wall probably goes on (never seen) may block a motion, near what was seen ...
    assert blocked[model.cell_of(-0.7, 0.5)] < blocked[model.cell_of(-0.55, 0.5)] < 0.0
    assert blocked[model.cell_of(-0.3, 0.5)] == 0.0 and blocked[model.cell_of(1.5, 0.5)] == 0.0
    # ... never where a beam saw free space, nor on the sensed cells themselves (lethal there).
    assert blocked[model.cell_of(-1.0, 0.3)] == 0.0 and blocked[model.cell_of(-1.0, 0.5)] == 0.0
    assert blocked[model.cell_of(-0.9, 0.0)] == 0.0
    # The heuristic's view follows the sensed cells alone, observed or not.
    assert model.continuation()[model.cell_of(-1.0, 0.3)] < 0.0


def test_cells_and_export():
    model = WorldModel(Bounds(-1.0, 1.02, -0.5, 0.5))
    assert model.occupied().shape == (41, 20)  # the last column overhangs the bounds
    assert model.cell_of(-1.0, -0.5) == (0, 0)
    assert model.centre_of(*model.cell_of(0.33, 0.11)) == pytest.approx((0.325, 0.125))
    for _ in range(2):
        model.integrate([ray((0.0, 0.0), math.pi / 2, 0.3)])
    data = json.loads(json.dumps(model.to_dict()))
    assert data["resolution"] == RES and data["origin"] == [-1.0, -0.5] and data["size"] == [41, 20]
    assert data["sensed"] == [[0.025, 0.325]] or data["sensed"] == [[-0.025, 0.325]]
    assert data["contact"] == [] and data["version"] == model.version
    assert data["soft_version"] == model.soft_version


def test_simulator_readings_become_observations():
    hidden = (Circle(-0.8, 0.05, 0.15, known=False), rectangle(0.7, 0.0, 0.1, 1.0, known=False))
    world = World(Bounds(-2.0, 2.0, -2.0, 2.0), hidden)
    sensors = forward_ir(noise_std=SIGMA) + range_ring(8, 1.0, SIGMA)
    suite = SensorSuite(sensors, rng=np.random.default_rng(6))
    pose = np.array([0.0, 0.0, 0.1])  # the head faces ψ + π: towards the circle
    model = WorldModel(world.bounds)
    for _ in range(6):
        readings = suite.read(world, pose, np.zeros(3), dropped=frozenset({"ring3"}))
        obs = range_observations(sensors, pose, readings.ranges)
        model.integrate(obs)
    assert obs[0].origin == pytest.approx(tuple(head_tip(pose)))
    assert obs[0].angle == pytest.approx(0.1 + math.pi) and obs[0].fov == sensors[0].fov
    assert obs[1].fov == 0.0 and obs[2].angle == pytest.approx(0.1 + math.pi + math.pi / 4)
    seen = [readings.hits[s.name] != -2 for s in sensors]
    assert [o.hit for o in obs] == [
        h and s.name != "ring3" for h, s in zip(seen, sensors, strict=True)
    ]
    assert sum(seen) >= 3 and not all(seen)  # noisy empty readings (< max_range) are not hits
    assert math.isnan(obs[4].distance)  # ring3 dropped out
    centres = sensed_centres(model)
    assert len(centres) >= 1
    assert surface_distance(world, centres).max() <= 2 * SIGMA + RES


def test_invalid_settings_and_observations_are_rejected():
    with pytest.raises(ValueError):
        CostmapSettings(resolution=0.0)
    with pytest.raises(ValueError):
        CostmapSettings(ambiguous_ceiling=2.0)
    with pytest.raises(ValueError):
        CostmapSettings(sample_step=1.5)
    with pytest.raises(ValueError):
        CostmapSettings(contact_probability=1.0)
    with pytest.raises(ValueError):
        CostmapSettings(contact_half_life=0.0)
    with pytest.raises(ValueError):
        RangeObservation((0.0, 0.0), 0.0, -0.1, 1.0, 0.5, True)
    with pytest.raises(ValueError):
        RangeObservation((0.0, math.inf), 0.0, 0.0, 1.0, 0.5, True)

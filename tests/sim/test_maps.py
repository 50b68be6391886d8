"""Maps in ROS map_server's format: the image's orientation and origin, map_server's shades and
thresholds in every mode, the raster the simulator collides with and senses, and bad maps."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim import collision_kernel
from sim.maps import MapError, MapParams, classify, decode, encode_pgm, load_raster
from sim.raster import FREE, OCCUPIED, OUTSIDE, UNKNOWN, OccupancyRaster, segment_box_distance
from sim.world import Bounds, World, footprint
from tests.maps_fixtures import pgm, png

# A hand-made 3 x 2 image, row 0 the top: black (occupied) top-left and bottom-right,
# grey (128: p = 0.498, unknown) top-middle, white (free) elsewhere.
THREE_BY_TWO = np.array([[0, 128, 254], [254, 254, 0]], dtype=np.uint8)


def test_row_zero_is_the_top_and_the_origin_is_the_lower_left_corner() -> None:
    raster = load_raster(pgm(THREE_BY_TWO), MapParams(1.0, (10.0, 20.0, 0.0)), 100)
    assert raster.shape == (3, 2)  # i along x (the image's columns), j along y
    # the bottom row (image row 1) is j = 0
    assert raster.cells[:, 0].tolist() == [FREE, FREE, OCCUPIED]
    assert raster.cells[:, 1].tolist() == [OCCUPIED, UNKNOWN, FREE]
    assert raster.extent() == (10.0, 13.0, 20.0, 22.0)
    # cell centres at origin + (i + 1/2, j + 1/2) * resolution
    centres = raster.cell_centres(np.array([0, 2]), np.array([1, 0]))
    assert centres.tolist() == [[10.5, 21.5], [12.5, 20.5]]
    probes = np.array([[10.5, 21.5], [12.5, 20.5], [11.5, 21.5], [10.5, 20.5], [9.9, 20.5]])
    assert raster.classes_at(probes).tolist() == [OCCUPIED, OCCUPIED, UNKNOWN, FREE, OUTSIDE]
    # the lower-left pixel's corner is the origin: just inside it is the bottom-left cell
    assert raster.classes_at(np.array([[10.001, 20.001]])).tolist() == [FREE]


def test_a_yaw_turns_the_map_about_its_origin() -> None:
    raster = load_raster(pgm(THREE_BY_TWO), MapParams(1.0, (1.0, 2.0, math.pi / 2)), 100)
    # the map's x runs along the world's y: cell (i, j) centre = origin + R(90°)(i + ½, j + ½)
    (x, y) = raster.cell_centres(np.array([0]), np.array([1]))[0]
    assert (x, y) == pytest.approx((1.0 - 1.5, 2.0 + 0.5))
    assert raster.classes_at(np.array([[x, y]])).tolist() == [OCCUPIED]
    assert raster.extent() == pytest.approx((-1.0, 1.0, 2.0, 5.0))


def test_16_bit_pgm_and_png_read_as_8_bit() -> None:
    params = MapParams(0.5)
    eight = load_raster(pgm(THREE_BY_TWO), params, 100).cells
    sixteen = load_raster(pgm(THREE_BY_TWO.astype(np.uint32) * 257, 65535), params, 100).cells
    grey_png = load_raster(png(THREE_BY_TWO), params, 100).cells
    assert np.array_equal(eight, sixteen)
    assert np.array_equal(eight, grey_png)
    sixteen_png = png(THREE_BY_TWO.astype(np.uint16) * 257, "I;16")
    assert decode(sixteen_png, 100).depth == 16
    assert np.array_equal(load_raster(sixteen_png, params, 100).cells, eight)


def test_colour_channels_are_averaged_not_luma() -> None:
    # pure red: luma would read 76 (occupied); map_server's mean is 85 -> p = 0.667 (occupied
    # over 0.65); (0, 0, 255) blue: the same mean, the same class; (255, 255, 0) yellow: mean
    # 170 -> p = 0.333: unknown, where luma (226) would say free
    rgb = np.array([[[255, 0, 0], [0, 0, 255], [255, 255, 0]]], dtype=np.uint8)
    cls, _ = classify(decode(png(rgb, "RGB"), 100), MapParams(1.0))
    assert cls.tolist() == [[OCCUPIED, OCCUPIED, UNKNOWN]]
    # trinary: alpha (opacity) averaged in, as map_server does: white but transparent is
    # mean (255 + 255 + 255 + 0) / 4 -> p = 0.25: unknown with free_thresh 0.25
    rgba = np.array([[[255, 255, 255, 0], [255, 255, 255, 255]]], dtype=np.uint8)
    cls, _ = classify(decode(png(rgba, "RGBA"), 100), MapParams(1.0))
    assert cls.tolist() == [[UNKNOWN, FREE]]
    # scale: alpha not averaged, a transparent pixel is unknown
    cls, value = classify(decode(png(rgba, "RGBA"), 100), MapParams(1.0, mode="scale"))
    assert cls.tolist() == [[UNKNOWN, FREE]] and value.tolist() == [[-1, 0]]


def test_negate_and_thresholds() -> None:
    shades = np.array([[0, 60, 128, 200, 255]], dtype=np.uint8)
    # p = (255 - v) / 255: 1.0, 0.765, 0.498, 0.216, 0
    cls, value = classify(decode(pgm(shades), 100), MapParams(1.0))
    assert cls.tolist() == [[OCCUPIED, OCCUPIED, UNKNOWN, FREE, FREE]]
    assert value.tolist() == [[100, 100, -1, 0, 0]]
    cls, _ = classify(decode(pgm(shades), 100), MapParams(1.0, negate=True))
    assert cls.tolist() == [[FREE, FREE, UNKNOWN, OCCUPIED, OCCUPIED]]
    # scale: between the thresholds, map_server's probability (rint of the ratio, 1-99)
    _, value = classify(decode(pgm(shades), 100), MapParams(1.0, mode="scale"))
    assert value.tolist() == [[100, 100, round((0.498 - 0.25) / 0.4 * 100), 0, 0]]
    # raw: the value is the percentage, past 100 unknown
    raw = np.array([[0, 50, 100, 101, 255]], dtype=np.uint8)
    cls, value = classify(decode(pgm(raw), 100), MapParams(1.0, mode="raw"))
    assert value.tolist() == [[0, 50, 100, -1, -1]]
    assert cls.tolist() == [[FREE, UNKNOWN, OCCUPIED, UNKNOWN, UNKNOWN]]


@pytest.mark.parametrize(
    ("data", "params", "field"),
    [
        (b"GIF89a....", MapParams(1.0), "image"),
        (b"P2\n3 2\n255\n0 0 0 0 0 0", MapParams(1.0), "image"),  # ASCII PGM: not map_server's
        (b"P5\n3 2\n255\n\x00\x00", MapParams(1.0), "image"),  # cut short
        (b"\x89PNG\r\n\x1a\n" + b"\x00" * 40, MapParams(1.0), "image"),
        (pgm(THREE_BY_TWO), MapParams(0.0), "resolution"),
        (pgm(THREE_BY_TWO), MapParams(-1.0), "resolution"),
        (pgm(THREE_BY_TWO), MapParams(1.0, (math.nan, 0.0, 0.0)), "origin"),
        (pgm(THREE_BY_TWO), MapParams(1.0, (0.0, math.inf, 0.0)), "origin"),
        (pgm(THREE_BY_TWO), MapParams(1.0, occupied_thresh=0.2, free_thresh=0.3), "free_thresh"),
        (pgm(THREE_BY_TWO), MapParams(1.0, occupied_thresh=1.5), "occupied_thresh"),
    ],
)
def test_bad_maps_name_the_parameter(data: bytes, params: MapParams, field: str) -> None:
    with pytest.raises(MapError) as caught:
        load_raster(data, params, 100)
    assert caught.value.field == field


def test_an_image_over_the_pixel_limit_is_refused_before_decoding() -> None:
    big = b"P5\n100000 100000\n255\n"  # ten billion pixels announced, none sent
    with pytest.raises(MapError, match="at most 1000000"):
        load_raster(big, MapParams(1.0), 1_000_000)


def test_map_saver_pgm_reads_back_as_the_same_cells() -> None:
    raster = load_raster(pgm(THREE_BY_TWO), MapParams(1.0), 100)
    # map_saver's YAML says free_thresh 0.196: its unknown shade 205 reads p = 0.196
    again = load_raster(encode_pgm(raster.cells), MapParams(1.0, free_thresh=0.196), 100)
    assert np.array_equal(raster.cells, again.cells)


def wall_world(yaw: float = 0.0) -> tuple[World, OccupancyRaster]:
    """A 5 m map at 0.05 m with a wall of cells at x in [0.5, 0.6) (yaw 0)."""
    cells = np.zeros((100, 100), dtype=np.int8)
    cells[60:62, :] = OCCUPIED
    raster = OccupancyRaster(cells, 0.05, (-2.5, -2.5, yaw))
    return World(Bounds(-5, 5, -5, 5), (), (raster,)), raster


def test_the_simulator_collides_with_occupied_cells_by_their_squares() -> None:
    world, _ = wall_world()
    # the straight body lies along +x from its head: its tail's axis ends `length` further
    probe = footprint(np.array([0.0, 0.0, 0.0]), np.zeros(3))
    length = float(np.max(np.concatenate([probe.starts[:, 0], probe.ends[:, 0]])))
    head = 0.5 - 0.075 - 0.2 - length  # the tail capsule 0.2 m from the wall's face
    clear = footprint(np.array([head, 0.0, 0.0]), np.zeros(3))
    assert world.contact(clear) is None
    gap = world.gap(clear)
    assert gap == pytest.approx(0.2, abs=1e-9)
    assert world.free_within(clear, gap - 1e-6) and not world.free_within(clear, gap + 1e-6)
    touching = footprint(np.array([head + 0.25, 0.0, 0.0]), np.zeros(3))
    contact = world.contact(touching)
    assert contact is not None and contact.what == "map 0" and contact.obstacle == 0
    assert contact.part == 4 and contact.side == "rear"  # the tail unit, its rear end


def test_rays_hit_the_first_occupied_cell() -> None:
    world, raster = wall_world()
    angles = np.linspace(-1.2, 1.2, 9)
    dirs = np.stack([np.cos(angles), np.sin(angles)], axis=-1)
    dist, what = world.ray_cast(np.array([0.0, 0.0]), dirs, 2.0)
    assert np.allclose(dist, np.minimum(0.5 / np.cos(angles), 2.0))
    assert what.tolist() == [0 if d < 2.0 else -2 for d in dist]
    # the same map turned by a yaw about its origin: the same distances along turned rays
    yaw = 0.7
    turned, _ = wall_world(yaw=yaw)
    rot = np.array([[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]])
    corner = np.array([-2.5, -2.5])
    origin = corner + rot @ (np.zeros(2) - corner)
    turned_dist, _ = turned.ray_cast(origin, dirs @ rot.T, 2.0)
    assert np.allclose(turned_dist, dist)
    # from inside an occupied cell: 0
    assert raster.ray_cast(np.array([0.55, 0.0]), dirs, 1.0).tolist() == [0.0] * 9


@pytest.mark.skipif(not collision_kernel.AVAILABLE, reason="numba kernels off")
def test_compiled_raster_gaps_equal_numpy() -> None:
    rng = np.random.default_rng(3)
    cells = (rng.random((40, 30)) < 0.1).astype(np.int8)
    raster = OccupancyRaster(cells, 0.05, (-1.0, -0.75, 0.4))
    for _ in range(200):
        a = rng.uniform(-1.2, 1.2, (5, 2))
        b = a + rng.uniform(-0.2, 0.2, (5, 2))
        radii = np.full(5, 0.075)
        compiled = raster.segment_gap(a, b, radii, 0.3)
        local_a, local_b = raster.to_map(a), raster.to_map(b)
        low, high = raster.occupied_near(np.array([-10.0, -10.0]), np.array([10.0, 10.0]))
        for c in range(5):
            d = float(np.min(segment_box_distance(local_a[c], local_b[c], low, high)))
            assert compiled[c] == pytest.approx(min(d - 0.075, 0.3), abs=1e-12)


def test_the_planning_grid_covers_every_occupied_cell() -> None:
    # a map finer than the planning grid: a one-pixel (2.5 cm) wall must not fall between
    # the grid's cells
    cells = np.zeros((40, 40), dtype=np.int8)
    cells[21, :] = OCCUPIED
    raster = OccupancyRaster(cells, 0.025, (0.0, 0.0, 0.0))
    covered = raster.cover((0.0, 0.0), 0.05, (20, 20), OCCUPIED)
    assert covered[10, :].all() and covered.sum() == 20
    # a coarser one: each 0.1 m cell covers 2 x 2 grid cells exactly
    coarse = OccupancyRaster(np.array([[1, 0], [0, 0]], dtype=np.int8), 0.1, (0.0, 0.0, 0.0))
    assert coarse.cover((0.0, 0.0), 0.05, (4, 4), OCCUPIED).sum() == 4

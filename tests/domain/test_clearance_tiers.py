"""The clearance tiers: what each keeps clear of, and that each later tier keeps less."""

from __future__ import annotations

import numpy as np

from domain.clearance_tiers import (
    CONTACT_BARE,
    GOAL_UNSUSPECTED,
    Tier,
    _close_to,
    tier_clearance,
    tiers,
)
from domain.interpolate import bilinear
from domain.worldmodel import WorldModel
from sim.obstacles import Circle
from sim.world import Bounds

GOALS = [(1.2, 1.0), (-1.5, -0.5)]


def touched_world() -> WorldModel:
    """A 5 m arena with a known disc, contacts and suspected surfaces near and far from goals."""
    world = WorldModel(Bounds(-2.5, 2.5, -2.5, 2.5), [Circle(0.0, 0.0, 0.3)])
    for x, y in [(1.4, 1.1), (0.3, -1.4), (-1.2, -0.8), (-2.0, 1.5)]:
        world.add_contact((x, y))
    world.add_suspected([(1.0, 1.3), (1.05, 1.3), (1.1, 1.3), (-0.5, 0.2), (-0.55, 0.25)])
    return world


def test_off_goals_passes_closely_round_goals_and_avoids_elsewhere() -> None:
    world = touched_world()
    off = tier_clearance(world, Tier("off-goals"), GOALS)
    avoiding = tier_clearance(world, Tier("all"))
    rng = np.random.default_rng(3)
    pts = rng.uniform(-2.4, 2.4, (20_000, 2))
    centres = np.asarray(GOALS)
    dist = np.linalg.norm(pts[:, None, :] - centres, axis=-1).min(axis=-1)
    cell = world.grid.resolution
    inside, outside = dist < GOAL_UNSUSPECTED - 2 * cell, dist > GOAL_UNSUSPECTED + 2 * cell
    close_grid = world.inflated_grid(Tier("off-goals").sensed, CONTACT_BARE, suspected=True)
    want_inside = bilinear(close_grid, world.grid, pts[inside], world.bounds)
    np.testing.assert_array_equal(off(pts[inside]), want_inside)
    np.testing.assert_array_equal(off(pts[outside]), avoiding(pts[outside]))
    # The contacts near the goals are passed more closely there than the avoiding tier does.
    assert np.any(off(pts[inside]) > avoiding(pts[inside]))


def test_each_tier_keeps_at_most_what_the_one_before_keeps() -> None:
    """Every tier keeps at most what the avoiding first one keeps, and the loosest (last) tier
    at most what any keeps: reshaping's reachability pruning relies on that. (Round goals
    off-goals passes contacts more closely than the third tier does: they are not ordered.)"""
    world = touched_world()
    rng = np.random.default_rng(4)
    pts = rng.uniform(-2.5, 2.5, (20_000, 2))
    order = tiers(world.any_suspected())
    assert [t.suspected for t in order] == ["all", "off-goals", "none", "none"]
    values = [tier_clearance(world, tier, GOALS)(pts) for tier in order]
    for later in values[1:]:
        assert np.all(later >= values[0]) and np.any(later > values[0])
    for earlier in values[:-1]:
        assert np.all(values[-1] >= earlier)


def test_the_compiled_form_reads_the_same_clearance() -> None:
    world = touched_world()
    pts = np.random.default_rng(5).uniform(-2.6, 2.6, (5_000, 2))  # walls included
    for tier in tiers(True):
        clearance = tier_clearance(world, tier, GOALS)
        np.testing.assert_array_equal(clearance.grids()(pts), clearance(pts))


def test_the_cells_round_goals_are_those_a_scan_of_every_cell_finds() -> None:
    """The off-goals tier's close cells, found in a box round each goal, off-grid goals too."""
    world = touched_world()
    goals = [*GOALS, (2.4, -2.4), (3.5, 0.2), (-1.5, -0.5)]
    xs, ys = np.meshgrid(world.grid.xs, world.grid.ys, indexing="ij")
    dist = np.min([np.hypot(xs - gx, ys - gy) for gx, gy in goals], axis=0)
    np.testing.assert_array_equal(_close_to(world, goals), dist < GOAL_UNSUSPECTED)

"""The hard benchmark missions (examples/hard) are well-formed: they parse, declare what they
expect, start clear of everything, and an expected success is solvable for the body's width
while an expected `unreachable` really is cut off. Nothing here runs a mission end to end."""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage

from app.missions.spec import DropoutEvent, MissionSpec, load_mission
from sim.robot import Array
from sim.world import World, footprint

HARD = sorted(Path(__file__).parents[2].joinpath("examples", "hard").glob("*.json"))
DISC = 0.075  # a unit's capsule radius: the narrowest the body gets
GOAL_CLEARANCE = 0.12  # a goal this far from everything leaves the body 4.5 cm (the 0.25 m
# pocket of reshape-into-pocket; goals-near-walls keeps 0.15)
MAX_CELLS = 400  # raster cells per side (coarse is fine: corridors are 0.30 m)


@cache
def spec(path: Path) -> MissionSpec:
    return load_mission(path)


def world(s: MissionSpec) -> World:
    return World(s.bounds.bounds(), tuple(s.world_obstacles()))


def clearance(w: World, points: Array) -> Array:
    """Distance of points ``[N, 2]`` to the nearest obstacle (hidden ones too) or wall."""
    out = w.bounds.wall_clearance(points)
    for obstacle in w.obstacles:
        out = np.minimum(out, obstacle.segment_clearance(points, points))
    return out


def free(w: World, points: Array, radius: float) -> Array:
    """Whether a disc of ``radius`` centred at each point ``[N, 2]`` touches nothing."""
    ok = w.bounds.wall_clearance(points) >= radius
    for obstacle in w.obstacles:
        x0, y0, x1, y1 = obstacle.bounding_box()
        # Only points near the bounding box can touch: exact distances for those alone.
        near = (
            (points[:, 0] > x0 - radius)
            & (points[:, 0] < x1 + radius)
            & (points[:, 1] > y0 - radius)
            & (points[:, 1] < y1 + radius)
        )
        p = points[near]
        ok[near] &= obstacle.segment_clearance(p, p) >= radius
    return ok


@cache
def free_components(path: Path) -> tuple[Array, tuple[Array, Array], float]:
    """Labels of the free space of a disc of radius ``DISC`` on a raster (0 = blocked), the
    cell centres' axes and the cell size."""
    s = spec(path)
    b = s.bounds
    res = max(0.025, max(b.xmax - b.xmin, b.ymax - b.ymin) / MAX_CELLS)
    xs = np.arange(b.xmin + res / 2, b.xmax, res)
    ys = np.arange(b.ymin + res / 2, b.ymax, res)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    points = np.stack([gx.ravel(), gy.ravel()], axis=-1)
    space = free(world(s), points, DISC).reshape(gx.shape)
    labels, _ = ndimage.label(space)  # 4-connected: no squeezing diagonally between cells
    return labels, (xs, ys), res  # a tuple: the axes differ in length unless the arena is square


def labels_near(path: Path, x: float, y: float) -> set[int]:
    """Free components within two cells of a point (the point itself may sit off-centre)."""
    labels, axes, res = free_components(path)
    xs, ys = axes
    ix = np.flatnonzero(np.abs(xs - x) <= 2 * res)
    iy = np.flatnonzero(np.abs(ys - y) <= 2 * res)
    near = labels[np.ix_(ix, iy)]
    return {int(v) for v in near.ravel() if v}


def fits_straight(w: World, x: float, y: float, headings: int = 72) -> bool:
    """Whether the straight body, head point at (x, y), is clear at some heading."""
    for psi in np.linspace(-np.pi, np.pi, headings, endpoint=False):
        fp = footprint(np.array([x, y, psi]), np.zeros(3))
        if w.contact(fp) is None:
            return True
    return False


def test_enough_hard_missions_covering_every_kind() -> None:
    specs = [spec(p) for p in HARD]
    assert len(specs) >= 17
    assert len({s.name for s in specs}) == len(specs)
    hidden = [s for s in specs if any(not o.known for o in s.obstacles)]
    assert any(s.order == "any" and len(s.goals) >= 6 for s in hidden)
    assert any(s.sensors.noise == pytest.approx(0.02) for s in specs)
    assert any(isinstance(e, DropoutEvent) for s in specs for e in s.events)
    assert any(e.type == "deform" for s in specs for e in s.events)
    assert any(o.type == "polygon" for s in specs for o in s.obstacles)
    assert any(o.type == "rectangle" and o.angle for s in specs for o in s.obstacles)
    unreachable = [s for s in specs if s.expect and s.expect.reason == "unreachable"]
    assert any(all(o.known for o in s.obstacles) for s in unreachable)
    assert any(all(not o.known for o in s.obstacles) for s in unreachable)
    assert any(s.bounds.xmax - s.bounds.xmin >= 20 and len(s.goals) >= 3 for s in specs)


@pytest.mark.parametrize("path", HARD, ids=lambda p: p.stem)
def test_parses_and_declares_an_expectation(path: Path) -> None:
    s = spec(path)
    assert s.name == path.stem
    assert s.expect is not None, "every hard mission says what it expects"
    assert s.expect.status in ("succeeded", "failed")
    if s.expect.status == "failed":
        assert s.expect.reason, "an expected failure names its cause"
    assert s.goals, "hard missions are goal missions, not chains"


@pytest.mark.parametrize("path", HARD, ids=lambda p: p.stem)
def test_start_footprint_is_clear(path: Path) -> None:
    s = spec(path)
    pose = np.array([s.start.x, s.start.y, s.start.psi])
    fp = footprint(pose, np.array(s.start_joints()))
    assert world(s).contact(fp) is None


@pytest.mark.parametrize("path", HARD, ids=lambda p: p.stem)
def test_expected_outcome_matches_the_free_space(path: Path) -> None:
    s = spec(path)
    assert s.expect is not None
    start = labels_near(path, s.start.x, s.start.y)
    assert start, "the start lies in free space"
    w = world(s)
    reachable = [bool(labels_near(path, g.x, g.y) & start) for g in s.goals]
    if s.expect.status == "succeeded":
        for i, g in enumerate(s.goals):
            gap = float(clearance(w, np.array([[g.x, g.y]]))[0])
            assert gap >= GOAL_CLEARANCE - 1e-9, f"goal {i} is {gap:.3f} m from an obstacle"
            assert reachable[i], f"goal {i} is cut off from the start"
            assert fits_straight(w, g.x, g.y), f"goal {i}: the straight body fits no heading"
    elif s.expect.reason == "unreachable":
        assert not all(reachable), "every goal is reachable after all"


FAST = [p for p in HARD if (e := spec(p).expect) is not None and e.fast]


@pytest.mark.parametrize("path", FAST, ids=lambda p: p.stem)
def test_fast_hard_missions_end_as_they_expect(path: Path) -> None:
    """The cheap ones end to end (all of them run in `python -m bench.missions`)."""
    from app.executor.runner import MissionRunner
    from primitives.library import load_bundled

    s = spec(path)
    assert s.expect is not None
    runner = MissionRunner(s, load_bundled())
    result = runner.run()
    assert result.status == s.expect.status, result.reason
    if s.expect.reason:
        assert s.expect.reason in result.reason
    if result.status == "succeeded":
        assert all(
            g.reached and g.error is not None and g.error <= g.tolerance for g in result.goals
        )
    # Simulator truth: never a known obstacle or a wall; a hidden one at most once (found by touch).
    touched = [i for _, i in runner.robot.truth_contacts]  # type: ignore[attr-defined]
    assert all(i >= 0 and not s.obstacles[i].known for i in touched), touched
    assert len(touched) == len(set(touched)), touched


def test_at_least_six_fast_missions() -> None:
    assert len(FAST) >= 6

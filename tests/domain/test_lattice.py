"""The primitive lattice as a caller sees it: plans run library primitives and keep the margin
(checked against the simulator's geometry, not the costmap), tours are ordered, plans do not
depend on the hash seed, pyperplan's own searches and heuristics run on the same lattice, bad
names are clear errors."""

from __future__ import annotations

import dataclasses
import math
import os
import subprocess
import sys

import numpy as np
import pytest

from domain.goal_order import LegGoal
from domain.navigation import (
    SEARCH_NAMES,
    Failure,
    MotionTable,
    NavigationSettings,
    Plan,
    Planner,
    PlanRequest,
    leg_reach,
    motion_table,
)
from domain.navigation.lattice.grid import relative
from domain.world import CostmapSettings, WorldModel
from primitives.library import Library
from sim.obstacles import Circle, rectangle
from sim.robot import rotate
from sim.world import Bounds
from tests.domain.lattice_scenes import (
    ARC,
    LIB,
    SETTINGS,
    STRAIGHT,
    legs,
    move_slack,
    plan,
    scene,
    solved,
)

# Whole-lattice searches (pyperplan's blind and relaxed-plan ones) stay small.
COARSE = NavigationSettings(
    resolution=0.1, orientations=32, costmap=CostmapSettings(resolution=0.1)
)
COARSE_STRAIGHT = motion_table(LIB, "straight", (0.0, 0.0, 0.0), COARSE)
PERIODIC = motion_table(LIB, "periodic", (0.0, 0.0, 0.0), SETTINGS)


def interpolation(settings: NavigationSettings, table: MotionTable) -> float:
    """How much more than the truth the lethal layer may read between cell centres. The
    simulator's geometry is exact and the layer conservative at cell centres; between them it
    is bilinear, and a distance field curving round an obstacle's edge at radius rho (at least
    the clearance the point needs: its need plus the margin) is overshot over a cell of side h
    by at most h**2 / (8 rho)."""
    least = min(float(np.min(n)) for n in table.needs) + settings.margin
    return settings.resolution**2 / (8 * least)


SCENES = [
    ("wall-and-post", STRAIGHT),
    ("cluttered-1", STRAIGHT),
    ("cluttered-2", ARC),
    ("narrow-3", STRAIGHT),
    ("narrow-7", ARC),
    ("wall-and-post", PERIODIC),
]


def scene_of(name: str) -> tuple[Bounds, list, tuple[float, float, float], tuple[float, float]]:
    """Bounds, obstacles, start pose and goal of a named scene."""
    if name == "wall-and-post":
        obstacles = [rectangle(0.0, 0.0, 0.4, 3.0), Circle(-2.0, 1.5, 0.4)]
        return Bounds(-4, 4, -4, 4), obstacles, (2.0, 0.3, 0.0), (-2.5, -0.5)
    kind, seed = name.split("-")
    side = 5.0 if kind == "cluttered" else 4.0
    bounds, obstacles = scene(kind, side, int(seed))
    h = side / 2
    return bounds, obstacles, (-h + 0.9, -h + 0.7, 0.3), (h - 0.8, h - 0.8)


@pytest.mark.parametrize(("name", "table"), SCENES, ids=[s for s, _ in SCENES])
def test_plans_run_library_primitives_and_keep_the_margin(name: str, table) -> None:
    bounds, obstacles, pose, goal = scene_of(name)
    p, _, out = plan(bounds, obstacles, pose, [goal], table=table)
    result = solved(out)
    assert not result.partial and result.order == [0]
    moves = [a for a in result.actions if a.name == "move"]
    assert moves and result.actions[-1].name == "visit" and result.actions[-1].goal == 0
    assert moves[0].source == p.key_of(table, pose)  # from the robot's own state
    slack = move_slack(p, table, result, bounds, obstacles)
    # The first move leaves where the robot rests (it may rest closer than the margin).
    bound = interpolation(SETTINGS, table)
    assert slack[0] >= SETTINGS.start_margin - bound, slack[0]
    assert min(slack[1:]) >= SETTINGS.margin - bound, min(slack[1:])
    head = result.actions[-1].target[:2]
    assert math.dist(head, goal) <= leg_reach(LegGoal(0, *goal, 0.1)) + 1e-9
    # Costs are metres: at least the length of every motion, and the plan's cost their sum.
    lengths = [float(table.lengths[a.motion]) for a in moves if a.motion is not None]
    assert all(a.cost >= n - 1e-12 for a, n in zip(moves, lengths, strict=True))
    assert result.cost == pytest.approx(sum(a.cost for a in result.actions))


def test_unordered_goals_are_ordered_by_the_distance_maps() -> None:
    bounds = Bounds(-4, 4, -4, 4)
    goals = [(3.0, 3.0), (-3.0, -3.0), (2.5, 2.0)]
    _, _, given = plan(bounds, [], (0.0, 0.0, 0.0), goals, ordered=True)
    _, _, best = plan(bounds, [], (0.0, 0.0, 0.0), goals, ordered=False)
    given, best = solved(given), solved(best)
    assert given.order == [0, 1, 2]
    assert best.order in ([1, 2, 0], [2, 0, 1])  # never crosses the arena twice
    assert [a.goal for a in best.actions if a.name == "visit"] == best.order
    assert best.cost < given.cost
    assert len(best.legs) == len(given.legs) == 3


def test_the_heuristic_does_not_leak_through_a_thin_wall_beside_the_goal() -> None:
    """A 0.1 m wall with the goal 0.16 m beyond it: from just the other side of the wall the
    way goes round its end, though the goal is within the body's reach of there."""
    bounds = Bounds(-3, 3, -3, 3)
    world = WorldModel(bounds, [rectangle(1.5, -0.5, 0.1, 2.5)], SETTINGS.costmap)
    p = Planner(bounds, SETTINGS)
    goal = LegGoal(0, 1.71, -0.5, 0.1)
    distances = p.heuristic_map(STRAIGHT, world, goal, None)
    behind = distances[p.grid.cell(1.3, -0.5)]
    beside = distances[p.grid.cell(1.9, -0.5)]
    assert beside < 0.3
    assert behind > 1.5  # round the wall's end, 1.25 m away, and back


@pytest.mark.parametrize("search", [s for s in SEARCH_NAMES if s != "cost"])
def test_pyperplans_searches_run_on_the_same_lattice(search: str) -> None:
    """pyperplan's unit-cost searches take the planner's lattice task and obstacle heuristic:
    each finds a plan, valid and clear as the cost search's, and none costs less than the cost
    search's by more than its weight allows. Enforced hill climbing is incomplete: where it
    stops in a dead end the planner says timeout, never unreachable."""
    bounds = Bounds(-1.0, 1.0, -1.0, 1.0)
    obstacles = [Circle(0.1, 0.0, 0.15)]
    pose, goal = (-0.55, 0.6, 0.0), (0.5, -0.55)
    assert COARSE_STRAIGHT is not None
    runs = {}
    for name in ("cost", search):
        p, _, out = plan(
            bounds, obstacles, pose, [goal], table=COARSE_STRAIGHT, settings=COARSE,
            search=name, time_limit=60.0,
        )  # fmt: skip
        if name == "ehs" and isinstance(out, Failure):
            assert out.kind == "timeout" and out.proof is None, out
            assert "the ehs search gave up after" in out.reason, out.reason  # not the budget
            return
        result = solved(out)
        assert not result.partial and result.actions[-1].name == "visit"
        slack = move_slack(p, COARSE_STRAIGHT, result, bounds, obstacles)
        bound = interpolation(COARSE, COARSE_STRAIGHT)
        assert min(slack[1:], default=math.inf) >= COARSE.margin - bound
        runs[name] = result
    assert runs["cost"].cost <= COARSE.search.weight * runs[search].cost + 1e-9


@pytest.mark.parametrize("heuristic", ["hff", "hadd"])
def test_pyperplans_heuristics_stay_selectable_on_small_lattices(heuristic: str) -> None:
    bounds = Bounds(-1.0, 1.0, -1.0, 1.0)
    assert COARSE_STRAIGHT is not None
    p, _, out = plan(
        bounds, [], (-0.45, -0.3, 0.0), [(-0.45, 0.3)], table=COARSE_STRAIGHT, settings=COARSE,
        search="gbf", heuristic=heuristic, time_limit=60.0,
    )  # fmt: skip
    result = solved(out)
    assert result.actions[-1].name == "visit"
    assert min(move_slack(p, COARSE_STRAIGHT, result, bounds, [])) >= 0.0


def test_bad_search_or_heuristic_names_are_clear_errors() -> None:
    with pytest.raises(ValueError, match="search"):
        Planner(Bounds(), SETTINGS, search="dfs")
    with pytest.raises(ValueError, match="heuristic"):
        Planner(Bounds(), SETTINGS, heuristic="magic")
    with pytest.raises(ValueError, match="cost heuristic"):
        Planner(Bounds(), SETTINGS, search="cost", heuristic="hff")
    assert SEARCH_NAMES[0] == "cost" and set(SEARCH_NAMES) >= {"gbf", "astar", "wastar", "ehs"}


def test_a_shape_without_lattice_primitives_has_no_table() -> None:
    fixed = Library(e for e in LIB if e.shape != "arc" or e.family == "paper")
    assert motion_table(fixed, "arc", (0.3, 0.3, 0.3), SETTINGS) is None
    for shape in LIB.lattice_shapes():
        assert motion_table(LIB, shape, (0.0, 0.0, 0.0), COARSE) is not None


def test_a_gaits_motions_sweep_the_bending_body() -> None:
    """The periodic table's sample points are the body's as it bends along the cycle (a
    rigid sweep of the same poses keeps within the straight body), and its moves start and
    end in the straight shape."""
    assert PERIODIC is not None
    rigid = [dataclasses.replace(m, joints=None) for m in PERIODIC.motions]
    held = MotionTable("periodic", PERIODIC.joints, rigid, SETTINGS)
    assert PERIODIC.joints == pytest.approx([0.0, 0.0, 0.0])
    k = 0  # heading 0: the resting body lies along +x from the tracked point

    def points(table: MotionTable, m: int) -> np.ndarray:
        lo = int(table.segments[k][m])
        hi = int(table.segments[k][m + 1]) if m + 1 < len(table.motions) else None
        return table.points[k][lo:hi]

    along = 0
    for m, motion in enumerate(PERIODIC.motions):
        assert motion.joints is not None and len(motion.joints) == len(motion.swept)
        assert motion.joints[0] == pytest.approx([0, 0, 0], abs=1e-12)
        assert motion.joints[-1] == pytest.approx([0, 0, 0], abs=1e-12)
        if motion.turn == 0.0 and abs(float(motion.end[1])) < 0.01:  # along the body
            along += 1
            bent, straight = points(PERIODIC, m), points(held, m)
            gap = np.linalg.norm(bent[:, None, :] - straight[None, :, :], axis=-1).min(axis=1)
            assert 0.05 < float(np.max(gap)) < 0.1  # the tail swings out, by 0.09 m at most
    assert along == 4


def test_lattice_settings_are_checked() -> None:
    with pytest.raises(ValueError, match="orientations"):
        NavigationSettings(orientations=30)
    with pytest.raises(ValueError, match="margin"):
        NavigationSettings(margin=0.01, start_margin=0.02)
    with pytest.raises(ValueError, match="resolution"):
        NavigationSettings(resolution=0.1)  # the costmap's cells stay 0.05 m


def hash_seed_plan() -> list[str]:
    """A two-goal tour round a post, as PDDL (run in a subprocess per hash seed)."""
    _, _, out = plan(
        Bounds(-3, 3, -3, 3), [Circle(0, 0, 0.5)], (2.0, 0.2, 0.0), [(-2.0, -0.3), (0.0, 2.0)],
        ordered=False,
    )  # fmt: skip
    return solved(out).pddl_plan


def test_plans_do_not_depend_on_the_hash_seed() -> None:
    code = "from tests.domain.test_lattice import hash_seed_plan; print(hash_seed_plan())"
    runs = [
        subprocess.Popen(
            [sys.executable, "-c", code],
            env={**os.environ, "PYTHONHASHSEED": seed},
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        for seed in ("1", "2")
    ]  # side by side
    outs = set()
    for run in runs:
        out, err = run.communicate(timeout=300)
        assert run.returncode == 0, err
        outs.add(out)
    assert len(outs) == 1 and "(visit" in next(iter(outs))


def test_a_plan_request_reads_its_pose_on_the_lattice() -> None:
    """The plan starts from the lattice state of the robot's real pose (its centroid's cell and
    nearest heading) and every move's target is a lattice state's pose."""
    bounds = Bounds(-2, 2, -2, 2)
    world = WorldModel(bounds, [], SETTINGS.costmap)
    p = Planner(bounds, SETTINGS)
    pose = (0.013, -0.021, 0.05)
    out = p.plan(PlanRequest(pose, STRAIGHT, legs([(-1.0, 0.5)]), True, world))
    assert isinstance(out, Plan)
    i, j, k = p.key_of(STRAIGHT, pose)
    assert k == round(0.05 / SETTINGS.step)
    centroid = STRAIGHT.centroid(np.asarray(pose))
    assert p.grid.cell(float(centroid[0]), float(centroid[1])) == (i, j)
    for action in out.actions:
        key = p.key_of(STRAIGHT, action.target)
        np.testing.assert_allclose(p.pose_of(STRAIGHT, key), action.target, atol=1e-9)


def test_relative_is_the_inverse_pose_composed_with_the_target() -> None:
    rng = np.random.default_rng(3)
    for _ in range(500):
        pose, target = rng.uniform(-5, 5, size=3), rng.uniform(-5, 5, size=3)
        got = relative(tuple(pose), tuple(target))
        xy = rotate(target[:2] - pose[:2], np.array(-pose[2]))
        turn = math.remainder(float(target[2] - pose[2]), 2 * math.pi)
        assert np.allclose(got, [xy[0], xy[1], turn], rtol=0, atol=1e-12)


def test_a_tables_cell_checks_are_each_motions_own_and_keep_every_point() -> None:
    """Per bin and motion, the checked cells are where that motion's points fall (each once,
    sorted), a cell passes at the largest need there plus its point's offset and fails below
    the largest need less it, and the grouped points are the motion's own, cell by cell."""
    r = SETTINGS.resolution
    for k in (0, 7, 33):
        points, needs, segments = STRAIGHT.points[k], STRAIGHT.needs[k], STRAIGHT.segments[k]
        bounds = np.append(segments, len(points))
        cells_of, points_of = STRAIGHT.check_segments[k], STRAIGHT.check_points[k]
        for m in range(len(STRAIGHT.motions)):
            own, need = points[bounds[m] : bounds[m + 1]], needs[bounds[m] : bounds[m + 1]]
            at = np.floor(own / r + 0.5).astype(np.int64)
            off = np.abs(own - at * r).sum(axis=-1)
            cells = STRAIGHT.checks[k][cells_of[m] : cells_of[m + 1]]
            assert np.array_equal(cells, np.unique(at, axis=0))
            for c, cell in enumerate(cells, start=int(cells_of[m])):
                here = np.all(at == cell, axis=1)
                assert STRAIGHT.check_needs[k][c] == np.max(need[here] + off[here])
                assert STRAIGHT.check_fails[k][c] == np.max(need[here] - off[here])
                grouped = STRAIGHT.grouped[k][points_of[c] : points_of[c + 1]]
                assert np.array_equal(grouped, np.column_stack([own[here], need[here]]))

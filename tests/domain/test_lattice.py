"""The primitive lattice: grounding equals pyperplan's, plans are valid and clear, limits, reasons."""

import math
import os
import subprocess
import sys
import threading

import numpy as np
import pytest

from domain.goal_order import LegGoal
from domain.lattice import LatticeSettings, compose, motion_table
from domain.lattice_pddl import lattice_domain, lattice_problem
from domain.lattice_planner import LatticePlanner
from domain.lattice_task import LatticeTask
from domain.pyperplan_adapter import PlanResult, parse_and_ground, search_task, validate_plan
from domain.worldmodel import WorldModel
from primitives.library import load_bundled
from sim.obstacles import Circle, rectangle
from sim.world import Bounds, World, footprint

LIB = load_bundled()
SETTINGS = LatticeSettings()
STRAIGHT = motion_table(LIB, "straight", (0.0, 0.0, 0.0), SETTINGS)
# Whole-lattice groundings (for pyperplan's own heuristics and the export check) stay small.
COARSE = LatticeSettings(resolution=0.2, orientations=16)
COARSE_STRAIGHT = motion_table(LIB, "straight", (0.0, 0.0, 0.0), COARSE)


def planner(bounds: Bounds, **kw) -> LatticePlanner:
    return LatticePlanner(bounds, SETTINGS, **kw)


def plan(bounds, obstacles, pose, goals, ordered=True, **kw):
    world = WorldModel(bounds, obstacles)
    p = planner(bounds, **kw)
    assert STRAIGHT is not None
    legs = [LegGoal(i, x, y, 0.1) for i, (x, y) in enumerate(goals)]
    return (
        p,
        world,
        p.plan(
            STRAIGHT,
            world.clearance_at,
            world.version,
            pose,
            legs,
            ordered,
            static=(world.static_clearance_at, world.static_version),
        ),
    )


def operator_table(operators) -> set:
    def names(facts):
        return frozenset(str(f) for f in facts)

    return {
        (o.name, names(o.preconditions), names(o.add_effects), names(o.del_effects))
        for o in operators
    }


def test_direct_grounding_equals_pyperplans_grounding_of_the_export() -> None:
    bounds = Bounds(-1.0, 1.0, -1.0, 1.0)
    world = WorldModel(bounds, [Circle(0.7, 0.7, 0.15)])
    grid = LatticePlanner(bounds, COARSE).grid
    assert COARSE_STRAIGHT is not None
    start = (5, 5, 0)  # centroid at the middle of the 2 m x 2 m arena, heading 0
    task = LatticeTask(
        grid, COARSE_STRAIGHT, world.clearance_at, start, (0.3, 0.0), 0.15, 0.01, 0.0
    )
    task.ground_all()  # the whole reachable lattice
    assert len(task.operators) > 100
    problem = lattice_problem(task, "straight").text()
    # Without relevance pruning (pyperplan drops the moves into dead ends by default).
    pyperplans = parse_and_ground(lattice_domain().text(), problem, remove_irrelevant=False)
    assert operator_table(task.operators) == operator_table(pyperplans.operators)
    assert {str(f) for f in task.initial_state} == {str(f) for f in pyperplans.initial_state}
    assert {str(f) for f in task.goals} == {str(f) for f in pyperplans.goals}


def test_plans_run_library_primitives_and_keep_their_swept_footprint_clear() -> None:
    bounds = Bounds(-4, 4, -4, 4)
    obstacles = [rectangle(0.0, 0.0, 0.4, 3.0), Circle(-2.0, 1.5, 0.4)]
    p, _world, result = plan(bounds, obstacles, (2.0, 0.3, 0.0), [(-2.5, -0.5)])
    assert result.solved, result.reason
    moves = [a for a in result.actions if a.name == "move"]
    assert moves and result.actions[-1].name == "visit" and result.actions[-1].goal == 0
    truth = World(bounds, tuple(obstacles))
    here = np.array(p.pose_of(STRAIGHT, p.key_of(STRAIGHT, (2.0, 0.3, 0.0))))
    for a in moves:
        entry = LIB.get(a.primitive)  # every move names a library primitive
        assert entry.family == "lattice" and a.duration == entry.rollout.duration
        swept = compose(here, np.asarray(entry.swept))
        for pose in swept:
            assert truth.contact(footprint(pose, np.zeros(3))) is None
        here = np.array(a.target)
    head = np.array(result.actions[-1].target[:2])
    assert math.dist(head, (-2.5, -0.5)) <= 0.06


def test_the_plan_is_valid_on_the_task_and_the_export_solves_with_pyperplan() -> None:
    bounds = Bounds(-2.0, 2.0, -2.0, 2.0)
    _p, _world, result = plan(bounds, [Circle(0.0, 0.0, 0.3)], (0.4, 1.2, 0.0), [(-1.2, -1.0)])
    assert result.solved and result.task is not None
    result.task.operators = result.task.operators_seen()  # what the search generated
    assert validate_plan(result.task, result.pddl_plan) == (True, "valid")
    exported = parse_and_ground(
        lattice_domain().text(), lattice_problem(result.task, "straight").text()
    )
    again = search_task(exported, "astar", "blind", time_limit=30)
    assert again.solved
    assert validate_plan(exported, result.pddl_plan) == (True, "valid")


def test_unordered_goals_are_ordered_by_the_distance_table() -> None:
    bounds = Bounds(-4, 4, -4, 4)
    goals = [(3.0, 3.0), (-3.0, -3.0), (2.5, 2.0)]
    _, _, given = plan(bounds, [], (0.0, 0.0, 0.0), goals, ordered=True)
    _, _, best = plan(bounds, [], (0.0, 0.0, 0.0), goals, ordered=False)
    assert given.solved and best.solved
    assert given.order == [0, 1, 2]
    assert best.order in ([1, 2, 0], [2, 0, 1])  # never crosses the arena twice
    assert len(best.actions) < len(given.actions)


def test_enclosed_goals_are_unreachable_with_the_cause() -> None:
    bounds = Bounds(-4, 4, -4, 4)
    walls = [rectangle(2.0, 2.0 + d, 1.6, 0.2) for d in (-0.7, 0.7)]
    walls += [rectangle(2.0 + d, 2.0, 0.2, 1.6) for d in (-0.7, 0.7)]
    _, _, result = plan(bounds, walls, (-2.0, -2.0, 0.0), [(2.0, 2.0)])
    assert result.status == "unreachable"
    assert result.reason == "unreachable: goal 0 at (2, 2) enclosed by known obstacles"


def test_a_gap_narrower_than_the_body_is_unreachable_and_a_030_corridor_is_not() -> None:
    bounds = Bounds(-3, 3, -3, 3)

    def barrier(gap: float) -> list:
        half = (6 - gap) / 4
        return [rectangle(0.0, 3 - half, 0.3, 2 * half), rectangle(0.0, -3 + half, 0.3, 2 * half)]

    _, _, narrow = plan(bounds, barrier(0.12), (1.5, 0.0, 0.0), [(-1.5, 0.0)])
    assert narrow.status in ("unreachable", "unsolvable")
    assert narrow.reason.startswith("unreachable")
    _, _, corridor = plan(bounds, barrier(0.30), (1.5, 0.0, 0.0), [(-1.5, 0.0)])
    assert corridor.solved, corridor.reason


def test_time_limit_and_cancellation_end_the_search() -> None:
    bounds = Bounds(-10, 10, -10, 10)
    world = WorldModel(bounds, [])
    assert STRAIGHT is not None
    goal = [LegGoal(0, -9.0, -9.0, 0.1)]
    cancel = threading.Event()
    cancel.set()
    p = planner(bounds)
    out = p.plan(STRAIGHT, world.clearance_at, world.version, (9.0, 9.0, 0.0), goal, True, cancel)
    assert out.status == "cancelled"
    # A blind search cannot cross a 20 m arena in 0.2 s: it ends, it does not hang.
    slow = planner(bounds, search="astar", heuristic="blind", time_limit=0.2)
    out = slow.plan(STRAIGHT, world.clearance_at, world.version, (9.0, 9.0, 0.0), goal, True)
    assert out.status == "timeout" and "planning timeout" in out.reason


def test_pyperplan_heuristics_stay_selectable_on_small_lattices() -> None:
    bounds = Bounds(-1.0, 1.0, -1.0, 1.0)
    world = WorldModel(bounds, [])
    assert COARSE_STRAIGHT is not None
    for h in ("hff", "lmcut"):
        p = LatticePlanner(bounds, COARSE, heuristic=h, time_limit=60)
        out = p.plan(
            COARSE_STRAIGHT,
            world.clearance_at,
            world.version,
            (-0.45, -0.3, 0.0),
            [LegGoal(0, -0.45, 0.3, 0.3)],
            True,
        )
        assert out.solved, (h, out.reason)


def test_bad_search_or_heuristic_names_are_clear_errors() -> None:
    with pytest.raises(ValueError, match="search"):
        LatticePlanner(Bounds(), SETTINGS, search="dfs")
    with pytest.raises(ValueError, match="heuristic"):
        LatticePlanner(Bounds(), SETTINGS, heuristic="magic")


def test_a_shape_without_lattice_primitives_has_no_table() -> None:
    assert motion_table(LIB, "periodic", (0.0, 0.0, 0.0), SETTINGS) is None


def test_plans_do_not_depend_on_the_hash_seed() -> None:
    code = (
        "from tests.domain.test_lattice import plan; from sim.obstacles import Circle;"
        "from sim.world import Bounds;"
        "print(plan(Bounds(-3, 3, -3, 3), [Circle(0, 0, 0.5)], (2.0, 0.2, 0.0),"
        " [(-2.0, -0.3), (0.0, 2.0)], ordered=False)[2].pddl_plan)"
    )
    outs = set()
    for seed in ("1", "2"):
        env = {**os.environ, "PYTHONHASHSEED": seed}
        run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
        assert run.returncode == 0, run.stderr
        outs.add(run.stdout)
    assert len(outs) == 1


def test_motions_kept_between_replans_equal_a_fresh_check_after_a_local_change() -> None:
    bounds = Bounds(-3, 3, -3, 3)
    obstacles = [Circle(0.0, 0.8, 0.3), Circle(-1.0, -0.6, 0.25)]
    p, world, first = plan(bounds, obstacles, (2.2, -2.0, math.pi), [(-2.2, 2.0)])
    assert first.solved and STRAIGHT is not None
    moves = [a for a in first.actions if a.name == "move"]
    ahead = moves[len(moves) // 2].target
    world.add_contact((ahead[0], ahead[1]))  # something found on the way
    goal = [LegGoal(0, -2.2, 2.0, 0.1)]
    again = p.plan(STRAIGHT, world.clearance_at, world.version, moves[1].target, goal, True)
    assert again.solved
    cache = p.motion_cache(STRAIGHT)
    assert len(cache.free) > 50  # states carried over and seen again
    m = p.settings.margin
    fresh = LatticeTask(p.grid, STRAIGHT, world.clearance_at, (0, 0, 0), (-2.2, 2.0), 0.06, m, m)
    for number, kept in cache.free.items():
        key = p.grid.decode(number)
        fresh.start_key = (-1, -1, -1)  # no state is the start: every one checked in full
        ok = np.zeros(len(STRAIGHT.motions), dtype=bool)
        ok[[m for _, m in fresh.valid_motions(key)]] = True
        assert np.array_equal(kept, ok), key


def test_each_clearance_family_keeps_its_own_motions_between_replans(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Plans alternating between two kinds of clearance (tiers) do not make each other's kept
    motions stale: the second plan of a family checks no state its first checked, and plans
    as a fresh planner does; the least recently used cache goes past the limit."""
    from domain import lattice_planner

    bounds = Bounds(-3, 3, -3, 3)
    world = WorldModel(bounds, [Circle(0.0, 0.8, 0.3), Circle(-1.0, -0.6, 0.25)])
    wide = WorldModel(bounds, [Circle(0.0, 0.8, 0.45), Circle(-1.0, -0.6, 0.4)])
    assert STRAIGHT is not None
    goal = [LegGoal(0, -2.2, 2.0, 0.1)]
    pose = (2.2, -2.0, math.pi)
    p = planner(bounds)
    kinds = {"near": world, "wide": wide}

    def run(kind: str, planner_: LatticePlanner) -> tuple[list[str], int]:
        w = kinds[kind]
        out = planner_.plan(
            STRAIGHT, w.clearance_at, (w.version, kind), pose, goal, True, family=kind
        )
        assert out.solved
        return out.pddl_plan, out.expansions

    def held(kind: str) -> int:  # states whose motions the family's cache holds
        cache = p.motion_cache(STRAIGHT, kind)
        return len(cache.free) + len(cache.compiled_free())

    first = {kind: run(kind, p) for kind in kinds}
    kept = {kind: held(kind) for kind in kinds}
    assert p.motion_cache(STRAIGHT, "near") is not p.motion_cache(STRAIGHT, "wide")
    assert all(kept.values())
    again = {kind: run(kind, p) for kind in kinds}  # nothing changed: every verdict kept
    assert again == first == {kind: run(kind, planner(bounds)) for kind in kinds}
    assert {kind: held(kind) for kind in kinds} == kept
    monkeypatch.setattr(lattice_planner, "MOTION_CACHES", 2)
    p.motion_cache(STRAIGHT, "near")  # used last: "wide" is the least recently used
    p.motion_cache(STRAIGHT, "third")
    assert len(p._motions) == 2
    assert held("near") == kept["near"]
    assert held("wide") == 0  # made anew


def test_the_distance_map_does_not_leak_through_a_thin_wall_beside_the_goal() -> None:
    # A 0.1 m wall with the goal 0.16 m beyond it: from just the other side of the wall the
    # way goes round its end, though the goal is within the body's reach of there.
    wall = [rectangle(1.5, -0.5, 0.1, 2.5)]
    p, world, _ = plan(Bounds(-3, 3, -3, 3), wall, (-2.0, -2.0, 0.0), [(1.71, -0.5)])
    assert STRAIGHT is not None
    goal = LegGoal(0, 1.71, -0.5, 0.1)
    dist = p.maps.distances(STRAIGHT, world.clearance_at, world.version, goal)
    behind = dist[p.grid.cell(1.3, -0.5)]
    beside = dist[p.grid.cell(1.9, -0.5)]
    assert beside < 0.3
    assert behind > 1.5  # round the wall's end, 1.25 m away, and back


def test_a_goal_known_reachable_is_not_tested_again_after_a_long_search(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """After a long search the planner asks whether the body can get there at all; a tier
    that keeps less clearance than one where it could is not asked again (``reachable``)."""
    bounds = Bounds(-2, 2, -2, 2)
    world = WorldModel(bounds, [Circle(0.0, 0.0, 0.3)])
    legs = [LegGoal(0, 1.4, 1.4, 0.1)]
    asked: list[bool] = []

    def long_search(task, distances):  # every search runs out of expansions
        return PlanResult("timeout", [], 1.0, task.budget, "search timeout")

    for known in (False, True):
        p = planner(bounds)
        monkeypatch.setattr(p, "_search", long_search)

        def counted(*args, real=p.reachability, known=known):
            asked.append(known)
            return real(*args)

        monkeypatch.setattr(p, "reachability", counted)
        assert STRAIGHT is not None
        got = p.plan(
            STRAIGHT, world.clearance_at, 0, (-1.4, -1.4, 0.0), legs, True, reachable=known
        )
        assert got.status == "timeout" and got.reachable == (not known)
    assert asked == [False]  # asked, found it reachable; then taken as known

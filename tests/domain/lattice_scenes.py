"""Scenes, plans and an independent check of them for the navigation tests.

``plan`` asks a ``Planner`` what a caller would (``PlanRequest -> Plan | Failure``) on a world
model holding the scene's obstacles as known; ``move_slack`` replays a plan's moves and measures
what each keeps from the scene's obstacles and walls with the simulator's geometry (``sim``),
never with the planner's own costmap.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from domain.goal_order import LegGoal
from domain.navigation import (
    Failure,
    MotionTable,
    NavigationSettings,
    Plan,
    Planner,
    PlanRequest,
    compose,
    motion_table,
)
from domain.world import RangeObservation, WorldModel
from primitives.library import load_bundled
from sim.obstacles import Circle, Obstacle, rectangle
from sim.robot import Array
from sim.world import Bounds, World, footprint

LIB = load_bundled()
SETTINGS = NavigationSettings()
_straight = motion_table(LIB, "straight", (0.0, 0.0, 0.0), SETTINGS)
_arc = motion_table(LIB, "arc", (0.0, 0.0, 0.0), SETTINGS)
assert _straight is not None and _arc is not None
STRAIGHT: MotionTable = _straight
ARC: MotionTable = _arc


def legs(goals: Sequence[tuple[float, float]], tolerance: float = 0.1) -> tuple[LegGoal, ...]:
    return tuple(LegGoal(i, x, y, tolerance) for i, (x, y) in enumerate(goals))


def plan(
    bounds: Bounds,
    obstacles: Sequence[Obstacle],
    pose: tuple[float, float, float],
    goals: Sequence[tuple[float, float]],
    ordered: bool = True,
    table: MotionTable = STRAIGHT,
    settings: NavigationSettings = SETTINGS,
    observed: bool = False,
    **planner: Any,
) -> tuple[Planner, WorldModel, Plan | Failure]:
    """A planner, the world model it planned on (the obstacles known; the arena looked round
    when ``observed``) and its answer."""
    world = WorldModel(bounds, obstacles, settings.costmap)
    if observed:
        looked_round(world)
    p = Planner(bounds, settings, **planner)
    return p, world, p.plan(PlanRequest(pose, table, legs(goals), ordered, world))


def solved(out: Plan | Failure) -> Plan:
    assert isinstance(out, Plan), out
    return out


def scene(kind: str, side: float, seed: int) -> tuple[Bounds, list[Obstacle]]:
    """A square arena of ``side`` metres: ``open``, ``cluttered`` (seeded random discs clear of
    the start and goal corners), ``narrow`` (a wall across it with a 0.5 m gap at a seeded
    place) or ``enclosed`` (the goal corner fenced by a ring of posts)."""
    h = side / 2
    bounds = Bounds(-h, h, -h, h)
    rng = np.random.default_rng(seed)
    obstacles: list[Obstacle] = []
    if kind == "cluttered":
        while len(obstacles) < int(side * side / 3):
            x, y = rng.uniform(-h + 0.4, h - 0.4, 2)
            if (
                math.hypot(x + h - 1.0, y + h - 1.0) > 0.8
                and math.hypot(x - h + 0.8, y - h + 0.8) > 0.6
            ):
                obstacles.append(Circle(float(x), float(y), float(rng.uniform(0.1, 0.3))))
    elif kind == "narrow":
        gap = float(rng.uniform(-0.5, 0.5))
        low, high = gap - 0.25, gap + 0.25
        obstacles += [
            rectangle(0.0, (-h + low) / 2, 0.1, low + h),
            rectangle(0.0, (high + h) / 2, 0.1, h - high),
        ]
    elif kind == "enclosed":
        gx = gy = h - 0.8
        obstacles += [
            Circle(gx + 0.45 * math.cos(a), gy + 0.45 * math.sin(a), 0.12)
            for a in np.linspace(0, 2 * math.pi, 13)[:-1]
        ]
    elif kind != "open":
        raise ValueError(kind)
    return bounds, obstacles


def exact_clearance(bounds: Bounds, obstacles: Sequence[Obstacle], points: Array) -> Array:
    """Metres from points ``[N, 2]`` to the nearest obstacle or wall (the simulator's shapes)."""
    out = bounds.wall_clearance(points)
    for obstacle in obstacles:
        out = np.minimum(out, obstacle.segment_clearance(points, points))
    return out


def move_slack(
    planner: Planner,
    table: MotionTable,
    plan: Plan,
    bounds: Bounds,
    obstacles: Sequence[Obstacle],
) -> list[float]:
    """Per move of ``plan``: the least clearance any of its swept sample points keeps beyond
    the clearance it needs (the body's radius there), measured exactly against ``obstacles``
    and the walls, from the state the move starts at. Checks on the way that the moves chain
    from state to state and that the library primitive's own recorded sweep touches nothing."""
    truth = World(bounds, tuple(obstacles))
    grid = planner.grid
    out = []
    here: Array | None = None
    for action in plan.actions:
        if action.name != "move":
            continue
        assert action.source is not None and action.motion is not None
        i, j, k = action.source
        start = planner.pose_of(table, action.source)
        if here is not None:  # each move starts where the one before landed
            np.testing.assert_allclose(start, here, atol=1e-9)
        motion = table.motions[action.motion]
        assert motion.primitive == action.primitive
        entry = LIB.get(motion.primitive)
        assert entry.family == "lattice" and action.duration == entry.rollout.duration
        bent = entry.swept_joints or [table.joints] * len(entry.swept)  # a gait's bends
        for pose, joints in zip(compose(start, np.asarray(entry.swept)), bent, strict=True):
            assert truth.contact(footprint(pose, np.asarray(joints))) is None, action.pddl
        seg = table.segments[k]
        lo = int(seg[action.motion])
        hi = int(seg[action.motion + 1]) if action.motion + 1 < len(seg) else len(table.points[k])
        points = grid.centre(i, j) + table.points[k][lo:hi]
        slack = exact_clearance(bounds, obstacles, points) - table.needs[k][lo:hi]
        out.append(float(np.min(slack)))
        here = np.asarray(action.target)
    return out


def looked_round(world: WorldModel) -> WorldModel:
    """The world model of a robot that has looked round the whole arena (free beams crossing
    it everywhere): what a replan meets in a mission, where the robot senses what it passes.
    In space never observed every detour pays the risk of the unknown and searches wider."""
    b = world.bounds
    for x in np.arange(b.xmin + 0.2, b.xmax, 0.4):
        for y in np.arange(b.ymin + 0.2, b.ymax, 0.4):
            world.integrate(
                RangeObservation((float(x), float(y)), float(a), 0.0, 0.5, 0.5, False)
                for a in np.linspace(-math.pi, math.pi, 120, endpoint=False)
            )
    return world


def sense_post(world: WorldModel, x: float, y: float, heading: float = math.pi) -> None:
    """Consistent echoes at (x, y) of a ray cast along ``heading`` from 0.5 m back (by default
    from the east) until its cell is sensed (lethal): three where nothing was seen, more where
    beams had crossed it free."""
    version = world.version
    origin = (x - 0.5 * math.cos(heading), y - 0.5 * math.sin(heading))
    for _ in range(20):
        world.integrate([RangeObservation(origin, heading, 0.0, 1.0, 0.5, True)])
        if world.version > version and world.sensed_occupied().any():
            return
    raise AssertionError("the post was not sensed")


def ahead(moves: list, pose, distance: float = 1.0) -> tuple[float, float]:
    """Where the plan's first move to end ``distance`` metres or more from ``pose`` ends."""
    x, y, _ = next(a.target for a in moves if math.dist(a.target[:2], pose[:2]) >= distance)
    return x, y

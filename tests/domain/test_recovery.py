"""The recoveries' motions: library primitives checked on the lethal layer before they run.
Back off moves away from the touched side and keeps clear; spin to sense takes the largest
turn that keeps clear, the way asked if it can; a shape change is checked along its sweep and
offered only for shapes whose lattice reaches the goals (a zigzag body that cannot enter a
narrow pocket changes to straight)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from app.missions.spec import load_mission
from domain.navigation import (
    Failure,
    NavigationStrategy,
    Planner,
    PlanRequest,
    back_off,
    motion_table,
    reshape_duration,
    reshape_options,
    spin,
)
from domain.navigation.lattice import motions
from domain.navigation.recovery import primitive_clear, sweep_keeps_clear
from domain.world import WorldModel
from primitives.shapes import SHAPES
from sim.obstacles import Circle, rectangle
from sim.world import Bounds, footprint
from tests.domain.lattice_scenes import LIB, SETTINGS, legs

POCKET = Path(__file__).parents[2] / "examples" / "hard" / "reshape-into-pocket.json"
ARENA = Bounds(-2, 2, -2, 2)
POSE = (0.0, 0.0, 0.0)  # the straight body lies along +x from the head at the origin
STRAIGHT_JOINTS = (0.0, 0.0, 0.0)
# Outward from each side of a unit at ψ = 0 (the head leads along -x; its left is -y).
OUTWARD = {"front": (-1.0, 0.0), "rear": (1.0, 0.0), "left": (0.0, -1.0), "right": (0.0, 1.0)}


def open_world(obstacles=()) -> WorldModel:
    return WorldModel(ARENA, obstacles, SETTINGS.costmap)


@pytest.mark.parametrize(("side", "part"), [("left", 3), ("right", 2), ("front", 0), ("rear", 4)])
def test_back_off_moves_away_from_the_touched_side(side: str, part: int) -> None:
    world = open_world()
    moves = back_off(LIB, "straight", STRAIGHT_JOINTS, world, POSE, side, part, SETTINGS)
    assert len(moves) == SETTINGS.recovery.back_off_steps
    here = np.asarray(POSE, dtype=float)
    for entry in moves:
        assert entry.family == "lattice" and entry.shape == "straight" and entry.turn == 0.0
        assert entry.end_pose is not None
        dx, dy = entry.end_pose[0], entry.end_pose[1]
        assert np.dot((dx, dy), OUTWARD[side]) < -0.9 * math.hypot(dx, dy)  # straight away
        assert primitive_clear(world, here, STRAIGHT_JOINTS, entry, SETTINGS.margin)


def test_back_off_from_a_wall_the_body_touches_moves_off_it() -> None:
    """The body rests 5 mm from a wall on its left: the back-off moves off it, and where a
    second wall closes the other side too, it moves along what it touches or not at all."""
    left_wall = rectangle(0.45, -0.08 - 0.1, 1.6, 0.2)
    world = open_world([left_wall])
    moves = back_off(LIB, "straight", STRAIGHT_JOINTS, world, POSE, "left", 3, SETTINGS)
    assert moves and all(m.end_pose is not None and m.end_pose[1] > 0.03 for m in moves)
    # moved off: the body keeps more from the wall after backing off than before
    before = np.min(world.clearance_at(footprint(np.asarray(POSE), np.zeros(3)).ends))
    shift = sum(m.end_pose[1] for m in moves if m.end_pose is not None)
    after_pose = np.array([POSE[0], POSE[1] + shift, POSE[2]])
    after = np.min(world.clearance_at(footprint(after_pose, np.zeros(3)).ends))
    assert after > before
    boxed = open_world([left_wall, rectangle(0.45, 0.08 + 0.1, 1.6, 0.2)])
    for m in back_off(LIB, "straight", STRAIGHT_JOINTS, boxed, POSE, "left", 3, SETTINGS):
        assert m.end_pose is not None and abs(m.end_pose[1]) < 0.01  # never into a wall


def test_a_back_off_a_contact_stopped_is_not_begun_again_from_there() -> None:
    """A contact stopped the first move of a back-off (what the body touches is not where
    the world model shows it): from the same place the next back-off begins with another
    translation, the nearest to straight away after it, still one that keeps clear."""
    world = open_world()
    first = back_off(LIB, "straight", STRAIGHT_JOINTS, world, POSE, "left", 3, SETTINGS)
    again = back_off(
        LIB, "straight", STRAIGHT_JOINTS, world, POSE, "left", 3, SETTINGS, {first[0].id}
    )
    assert again and again[0].id != first[0].id
    assert again[0].end_pose is not None and again[0].end_pose[1] > 0  # still off the left side
    assert primitive_clear(world, np.asarray(POSE), STRAIGHT_JOINTS, again[0], SETTINGS.margin)


def test_spin_takes_the_largest_turn_that_keeps_clear() -> None:
    world = open_world()
    ccw = spin(LIB, "straight", STRAIGHT_JOINTS, world, POSE, SETTINGS, 1)
    cw = spin(LIB, "straight", STRAIGHT_JOINTS, world, POSE, SETTINGS, -1)
    assert ccw is not None and cw is not None
    largest = max(abs(e.turn) for e in LIB.lattice("straight"))
    assert ccw.turn == pytest.approx(largest) and cw.turn == pytest.approx(-largest)
    # A post beside the tail: the big turns swing the tail into it; a smaller one still fits,
    # or the other way round.
    posted = open_world([Circle(0.85, 0.25, 0.08)])
    turn = spin(LIB, "straight", STRAIGHT_JOINTS, posted, POSE, SETTINGS, 1)
    assert turn is not None
    assert primitive_clear(posted, POSE, STRAIGHT_JOINTS, turn, SETTINGS.margin)
    # In a tube the body just fits, no turn keeps clear.
    tube = open_world([rectangle(0.45, y, 1.8, 0.2) for y in (-0.2, 0.2)])
    assert spin(LIB, "straight", STRAIGHT_JOINTS, tube, POSE, SETTINGS, 1) is None


def test_a_shape_change_is_checked_along_its_sweep() -> None:
    zigzag, straight = np.asarray(SHAPES["zigzag"].joints), np.asarray(SHAPES["straight"].joints)
    pose = np.zeros(3)

    def bodies(a, b):
        return [(pose, a + s * (b - a)) for s in np.linspace(0.0, 1.0, 8)]

    assert sweep_keeps_clear(open_world(), pose, bodies(zigzag, straight), SETTINGS.margin)
    # A post where the straight body's tail would be, clear of the zigzag body's.
    tail = footprint(pose, straight).ends[-1]
    posted = open_world([Circle(float(tail[0]), float(tail[1]), 0.02)])
    fp = footprint(pose, zigzag)
    assert float(np.min(posted.clearance_at(fp.ends) - fp.radii)) > SETTINGS.margin
    assert not sweep_keeps_clear(posted, pose, bodies(zigzag, straight), SETTINGS.margin)
    # Joints turn at a bounded rate: 0.5 rad takes a second, in whole control ticks.
    assert reshape_duration(zigzag, straight, 0.25) == 1.0
    assert reshape_duration(straight, straight, 0.25) == 0.25


def test_a_zigzag_body_that_cannot_enter_a_pocket_is_offered_the_straight_shape() -> None:
    spec = load_mission(POCKET)
    assert spec.shape == "zigzag"
    world = WorldModel(spec.bounds.bounds(), [o for o in spec.world_obstacles() if o.known])
    goals = legs([(g.x, g.y) for g in spec.goals])
    pose = (spec.start.x, spec.start.y, spec.start.psi)
    zigzag = SHAPES["zigzag"].joints
    table = motion_table(LIB, "zigzag", zigzag, SETTINGS)
    assert table is not None
    out = Planner(world.bounds, SETTINGS).plan(PlanRequest(pose, table, goals, True, world))
    assert isinstance(out, Failure) and out.kind == "unreachable"  # not in this shape
    assert reshape_options(LIB, "zigzag", zigzag, world, pose, goals, SETTINGS) == ["straight"]
    # A goal no shape reaches (inside the pocket's back wall): nothing to change into.
    walled = legs([(-2.6, 0.0)])
    assert reshape_options(LIB, "zigzag", zigzag, world, pose, walled, SETTINGS) == []


def test_reshape_options_read_the_tables_the_planner_plans_with() -> None:
    """Every shape the recovery weighs is checked on the motion table of its held joints,
    the one the strategy (and a warm worker) already has: weighing them makes no table."""
    spec = load_mission(POCKET)
    world = WorldModel(spec.bounds.bounds(), [o for o in spec.world_obstacles() if o.known])
    goals = legs([(g.x, g.y) for g in spec.goals])
    pose = (spec.start.x, spec.start.y, spec.start.psi)
    strategy = NavigationStrategy(LIB, Planner(world.bounds, SETTINGS))
    for shape in LIB.lattice_shapes():
        strategy.table_for(shape, SHAPES[shape].joints)
    made = len(motions._TABLES)
    reshape_options(LIB, "zigzag", SHAPES["zigzag"].joints, world, pose, goals, SETTINGS)
    assert len(motions._TABLES) == made

"""The motions the behaviour tree's recoveries run: library primitives checked on the lethal layer.

A recovery moves the robot without a plan: back off from a contact (short translations away
from the touched side, a bumper's reflex), spin to sense (the largest turn in place the body
can make, so the head's rays look round), or change into another library shape (that can be
taken where the body is and whose lattice reaches the goals). Each motion is a library
primitive run as it is, and each is checked first: its swept body keeps the margin from what
is lethal or, where the body already rests closer (it just touched something), never comes
closer than it is.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence

import numpy as np
from numpy.typing import ArrayLike

from domain.goal_order import LegGoal
from domain.navigation.feasibility import Feasibility
from domain.navigation.lattice.grid import LatticeGrid, compose
from domain.navigation.lattice.motions import HeadView, capsule_samples, held_joints, motion_table
from domain.navigation.plan import leg_reach
from domain.navigation.settings import NavigationSettings, RecoverySettings
from domain.world import WorldModel
from primitives.library import Library, Primitive
from primitives.shapes import shape_named
from sim.robot import Array
from sim.world import footprint

AWAY = {"front": 0, "rear": 180, "left": 90, "right": 270}  # body angle away from a side
RESHAPE_SAMPLES = 8  # intermediate bodies checked along a shape change


def sweep_keeps_clear(
    world: WorldModel,
    pose: ArrayLike,
    bodies: Sequence[tuple[Array, Array]],
    margin: float,
    deeper: float = 0.0,
) -> bool:
    """Whether a sweep through ``bodies`` (each: a tracked-point pose and joints, the first
    where the body is now) keeps ``margin`` from the lethal layer, or at no point comes closer
    than the resting body already is, less ``deeper`` (a robot that just touched something
    may move away along what it touches)."""
    first = True
    floor = margin
    for body_pose, joints in bodies:
        fp = footprint(body_pose, joints)
        points, needs = capsule_samples(fp.starts, fp.ends, fp.radii)
        slack = world.clearance_at(points) - needs
        if first:
            floor = min(margin, float(np.min(slack)) - deeper)
            first = False
        elif float(np.min(slack)) < floor:
            return False
    return True


def primitive_clear(
    world: WorldModel,
    pose: ArrayLike,
    joints: ArrayLike,
    entry: Primitive,
    margin: float,
    deeper: float = 0.0,
) -> bool:
    """Whether running ``entry`` from ``pose`` keeps clear (``sweep_keeps_clear``): the body
    held in ``joints``, or bending as a gait entry's swept joints say."""
    start = np.asarray(pose, dtype=float)
    ends = [(0.0, 0.0, 0.0), entry.end_pose or (0.0, 0.0, 0.0)]
    swept = np.asarray(entry.swept or ends, dtype=float)
    poses = compose(start[None, :], swept)
    held = np.asarray(joints, dtype=float)
    bent = [np.asarray(j, dtype=float) for j in entry.swept_joints] or [held] * len(poses)
    return sweep_keeps_clear(world, start, list(zip(poses, bent, strict=True)), margin, deeper)


def back_off(
    library: Library,
    shape: str,
    joints: ArrayLike,
    world: WorldModel,
    pose: ArrayLike,
    side: str | None,
    part: int | None,
    settings: NavigationSettings,
    stopped: Collection[str] = (),
) -> list[Primitive]:
    """Up to ``back_off_steps`` of the shape's shortest translations away from ``side`` of
    ``part`` (``None``: from whatever is closest), each checked from where the previous one
    leaves the body; the first free direction nearest to straight away is taken, except, as
    the first, the translations in ``stopped`` (a contact stopped them from here: they press
    into what the body touches, whatever the world model shows of it)."""
    steps = [e for e in library.lattice(shape) if e.turn == 0.0 and e.end_pose is not None]
    if not steps:
        return []
    # the shortest family by what each was learned for (its goal), not where it landed
    shortest = min(math.hypot(*e.goal) for e in steps)
    short = [e for e in steps if math.hypot(*e.goal) <= shortest + 1e-9]
    if side is None:
        away = _away_from_closest(world, pose, joints)
    else:
        away = AWAY.get(side, 0)
        if part == 4 and side in ("front", "rear"):
            away = 180  # the tail's end touched: go head first
    out: list[Primitive] = []
    here = np.asarray(pose, dtype=float)
    for step in range(settings.recovery.back_off_steps):
        ranked = sorted(short, key=lambda e: abs(math.remainder(_angle(e) - away, 360.0)))
        for entry in ranked:
            if step == 0 and entry.id in stopped:
                continue
            if primitive_clear(world, here, joints, entry, settings.margin, settings.touch_deeper):
                out.append(entry)
                assert entry.end_pose is not None
                here = compose(here, np.asarray(entry.end_pose, dtype=float))
                break
        else:
            break
    return out


def _angle(entry: Primitive) -> float:
    """A translation's direction in the body frame, degrees (0 = towards the tail)."""
    assert entry.end_pose is not None
    return math.degrees(math.atan2(entry.end_pose[1], entry.end_pose[0])) % 360.0


def _away_from_closest(world: WorldModel, pose: ArrayLike, joints: ArrayLike) -> float:
    """The body angle pointing away from the closest lethal point (degrees, body frame)."""
    fp = footprint(np.asarray(pose, dtype=float), np.asarray(joints, dtype=float))
    points, needs = capsule_samples(fp.starts, fp.ends, fp.radii)
    slack = world.clearance_at(points) - needs
    worst = points[int(np.argmin(slack))]
    r = world.grid.resolution
    gx = float(
        world.clearance_at((worst + np.array([r, 0.0]))[None])[0]
        - world.clearance_at((worst - np.array([r, 0.0]))[None])[0]
    )
    gy = float(
        world.clearance_at((worst + np.array([0.0, r]))[None])[0]
        - world.clearance_at((worst - np.array([0.0, r]))[None])[0]
    )
    world_angle = math.atan2(gy, gx) if (gx or gy) else float(np.asarray(pose, dtype=float)[2])
    return math.degrees(world_angle - float(np.asarray(pose, dtype=float)[2])) % 360.0


def spin(
    library: Library,
    shape: str,
    joints: ArrayLike,
    world: WorldModel,
    pose: ArrayLike,
    settings: NavigationSettings,
    direction: int = 1,
) -> Primitive | None:
    """The shape's largest turn in place that keeps clear from ``pose``, turning ``direction``
    (+1 counter-clockwise, -1 clockwise) if it can, else the other way; ``None`` if none can."""
    turns = [e for e in library.lattice(shape) if e.turn != 0.0]
    ranked = sorted(turns, key=lambda e: (-abs(e.turn), 0 if e.turn * direction > 0 else 1))
    for entry in ranked:
        if primitive_clear(world, pose, joints, entry, settings.margin):
            return entry
    return None


def reshape_duration(
    joints_from: ArrayLike,
    joints_to: ArrayLike,
    tick: float,
    rate: float = RecoverySettings.reshape_rate,
) -> float:
    """Model seconds a shape change takes: the largest joint travel at ``rate`` (rad per model
    second, ``RecoverySettings.reshape_rate``), in whole control ticks."""
    travel = float(np.max(np.abs(np.subtract(joints_to, joints_from))))
    return max(1, math.ceil(travel / rate / tick)) * tick


def reshape_options(
    library: Library,
    shape: str,
    joints: ArrayLike,
    world: WorldModel,
    pose: ArrayLike,
    goals: Sequence[LegGoal],
    settings: NavigationSettings,
    view: HeadView | None = None,
) -> list[str]:
    """The other library shapes the body can change into here (every intermediate body keeps
    clear) whose lattice the feasibility check lets reach every goal, nearest first. A
    periodic gait is no option: its start shape is the straight body's and it sweeps wider,
    so it reaches nothing the straight body cannot."""
    here = np.asarray(joints, dtype=float)
    others = sorted(
        (
            name
            for name in library.lattice_shapes()
            if name != shape and not shape_named(name).periodic
        ),
        key=lambda name: float(np.max(np.abs(np.asarray(shape_named(name).joints) - here))),
    )
    grid = LatticeGrid(world.bounds, settings)
    lethal = world.lethal_clearance()
    start = np.asarray(pose, dtype=float)
    out = []
    for name in others:
        target = np.asarray(shape_named(name).joints, dtype=float)
        bodies = [
            (start, here + s * (target - here)) for s in np.linspace(0.0, 1.0, RESHAPE_SAMPLES)
        ]
        if not sweep_keeps_clear(world, start, bodies, settings.margin):
            continue
        table = motion_table(library, name, held_joints(shape_named(name).joints), settings, view)
        if table is None:
            continue
        c = table.centroid(start)
        i, j = grid.cell(float(c[0]), float(c[1]))
        k = round(float(start[2]) / settings.step) % settings.orientations
        check = Feasibility(grid, table, lethal, settings.margin)
        if all(check.reaches((i, j, k), (g.x, g.y), leg_reach(g)) for g in goals):
            out.append(name)
    return out

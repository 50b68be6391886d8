"""Turning range readings into world knowledge: sensed obstacle points and reactive flags."""

from __future__ import annotations

import math

import numpy as np

from app.executor.context import MissionContext
from sim.obstacles import Circle
from sim.robot import head_tip
from sim.world import footprint

POINT_RADIUS = 0.1  # a sensed hit becomes a small disc; the roadmap inflation does the rest
MERGE_DISTANCE = 0.25  # hits closer than this to a known point add nothing new
KNOWN_SLACK = 0.05  # metres: a hit this close to the map's walls or known obstacles is them
REACTIVE_THRESHOLD = 0.6  # metres: obstacle(direction) is true below this range


def sensed_points(ctx: MissionContext) -> list[tuple[float, float]]:
    """World points where range sensors hit something now."""
    readings = ctx.readings
    if readings is None:
        return []
    x, y, psi = ctx.pose
    origin = head_tip(np.array([x, y, psi]))
    points = []
    for sensor in ctx.sim.sensors.range_sensors:
        d = readings.ranges.get(sensor.name, math.nan)
        if math.isnan(d) or d >= sensor.max_range - 1e-6:
            continue
        angle = psi + math.pi + sensor.angle
        points.append(
            (float(origin[0] + d * math.cos(angle)), float(origin[1] + d * math.sin(angle)))
        )
    return points


def new_obstacles(ctx: MissionContext) -> list[Circle]:
    """Hits not yet in the knowledge, as small discs (never the true hidden geometry)."""
    known = [(o.x, o.y) for o in ctx.knowledge.sensed if isinstance(o, Circle)]
    fresh: list[Circle] = []
    for px, py in sensed_points(ctx):
        p = np.array([[px, py]])
        near = [
            k
            for k in known + [(c.x, c.y) for c in fresh]
            if math.hypot(k[0] - px, k[1] - py) < MERGE_DISTANCE
        ]
        # walls and known obstacles are on the map already: a hit on them tells nothing new
        on_map = float(ctx.knowledge.bounds.wall_clearance(p)[0]) < KNOWN_SLACK or any(
            float(o.segment_clearance(p, p)[0]) < KNOWN_SLACK for o in ctx.knowledge.known
        )
        if not near and not on_map:
            fresh.append(Circle(px, py, POINT_RADIUS, name="sensed", known=False))
    return fresh


def range_towards(ctx: MissionContext, direction: float) -> float:
    """The smallest range reading of sensors pointing within 25° of a world direction."""
    readings = ctx.readings
    if readings is None:
        return math.inf
    psi = ctx.pose[2]
    best = math.inf
    for sensor in ctx.sim.sensors.range_sensors:
        gap = abs(math.remainder(psi + math.pi + sensor.angle - direction, 2 * math.pi))
        d = readings.ranges.get(sensor.name, math.nan)
        if gap <= math.radians(25) and not math.isnan(d) and d < sensor.max_range - 1e-6:
            best = min(best, d)
    return best


BODY_LOOKAHEAD = 0.3  # metres the body is swept ahead when checking a direction
BODY_MARGIN = 0.08


def body_blocked(ctx: MissionContext, direction: float) -> bool:
    """Would the whole body, moved a little in ``direction``, come near a known or sensed
    obstacle? The head's sensors cannot see what the trailing body is about to touch."""
    x, y, psi = ctx.pose
    step = BODY_LOOKAHEAD * np.array([math.cos(direction), math.sin(direction)])
    poses = np.array([[x, y, psi], [x + step[0], y + step[1], psi]])
    fp = footprint(poses, ctx.sim.joints)
    starts, ends, radii = fp.starts, fp.ends, fp.radii
    for ob in ctx.knowledge.obstacles:
        now = ob.segment_clearance(starts[0], ends[0]) - radii
        ahead = ob.segment_clearance(starts[1], ends[1]) - radii
        if float(np.min(ahead)) < BODY_MARGIN and float(np.min(ahead)) <= float(np.min(now)):
            return True
    return False


def blocked_towards(ctx: MissionContext, direction: float) -> bool:
    return range_towards(ctx, direction) < REACTIVE_THRESHOLD or body_blocked(ctx, direction)

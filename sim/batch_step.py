"""One closed-loop step of K robots at once: fixed-shape kinematics, collisions, range readings.

The stepping ``Simulator`` moves one robot per call; this module takes the same step for a
stack of K robots in one world, with the same formulas so that each row equals what a
``Simulator`` gives for that robot (to rounding): one Euler step of ``body_twist``, a footprint
that stops before the first contact, and the head's range sensors by ray casting. Robots whose
whole step is clear of everything (the common case) move together; the few near an obstacle are
swept in sub-steps one by one, exactly as ``Simulator`` does. Scheduled events (deformations,
sensor dropouts) are not modelled here.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from sim.controls import clamp_joints
from sim.obstacles import EPS, unit_vectors
from sim.robot import Array, RobotGeometry, body_twist, head_tip, joint_positions, rotate
from sim.scene import Scene
from sim.sensors import SensorSuite
from sim.world import Contact, Footprint, World, footprint, footprint_of

Mask = NDArray[np.bool_]


def _points(pose: Array, phi: Array, geometry: RobotGeometry) -> tuple[Array, Array]:
    """Joint positions ``[K, 5, 2]`` and head tips ``[K, 2]``."""
    return joint_positions(pose, phi, geometry), head_tip(pose, geometry)


def gaps(world: World, scene: Scene, fp: Footprint, margin: Array) -> Array:
    """Each of K footprints' (``[K, 5, 2]`` capsule ends) smallest gap to a wall or an obstacle,
    negative when they overlap, for deciding whether it is below ``margin`` ``[K]`` (or 0).

    A footprint's obstacles are measured only when some bounding box comes within ``margin`` plus
    the largest radius of its capsule axes (``World``'s own cut): the others are further than
    ``margin`` and cannot change the decision, so the gap may read larger than they are.
    """
    ends = np.concatenate([fp.starts, fp.ends], axis=-2)  # [K, 10, 2]
    radii = np.concatenate([fp.radii, fp.radii])
    gap = np.min(world.bounds.wall_clearance(ends) - radii, axis=-1)
    if not scene.count:
        return np.asarray(gap)
    reach = (margin + float(np.max(fp.radii)))[:, None]
    lo, hi, b = ends.min(axis=1), ends.max(axis=1), scene.boxes
    close = (
        (b[:, 0] <= hi[:, :1] + reach)
        & (b[:, 2] >= lo[:, :1] - reach)
        & (b[:, 1] <= hi[:, 1:] + reach)
        & (b[:, 3] >= lo[:, 1:] - reach)
    )  # [K, N]
    near = np.flatnonzero(close.any(axis=1))
    if near.size:
        starts, stops = fp.starts[near].reshape(-1, 2), fp.ends[near].reshape(-1, 2)
        clearance = scene.segment_clearance(starts, stops)
        clearance = clearance.reshape(near.size, len(fp.radii), scene.count) - fp.radii[:, None]
        gap[near] = np.minimum(gap[near], clearance.min(axis=(1, 2)))
    return np.asarray(gap)


def free_within(world: World, scene: Scene, fp: Footprint, distance: Array) -> Mask:
    """``World.free_within`` for K footprints and distances ``[K]``."""
    return np.asarray(distance <= np.maximum(gaps(world, scene, fp, distance), 0.0))


def overlaps(world: World, scene: Scene, fp: Footprint) -> Mask:
    """Whether each of K footprints touches a wall or an obstacle (``World.contact`` is not
    ``None``: a clearance below a radius is a negative gap)."""
    return np.asarray(gaps(world, scene, fp, np.zeros(fp.starts.shape[0])) < 0)


def step_fixed_shapes(
    world: World,
    scene: Scene,
    geometry: RobotGeometry,
    pose: Array,
    joints: Array,
    theta: Array,
    phi: Array,
    dt: float,
    check_step: float,
) -> tuple[Array, Array, list[Contact | None]]:
    """Advance K robots at ``pose`` ``[K, 3]`` with ``joints`` ``[K, 3]`` by ``dt`` under screw
    speeds ``theta`` ``[K, 4]`` holding joint angles ``phi`` ``[K, 3]``: the new poses, joints and
    each robot's contact (``None`` when its step was free), as ``Simulator.step`` moves them."""
    phi = clamp_joints(phi, geometry)
    twist = body_twist(theta, phi, None, geometry)  # [K, 3], body frame
    velocity = np.concatenate([rotate(twist[:, :2], pose[:, 2]), twist[:, 2:]], axis=-1)
    target = pose + dt * velocity
    js0, tip0 = _points(pose, phi, geometry)
    js1, tip1 = _points(target, phi, geometry)
    points0 = np.concatenate([js0, tip0[:, None, :]], axis=1)
    points1 = np.concatenate([js1, tip1[:, None, :]], axis=1)
    # The same chord allowance as Simulator._sweep (arcs are slightly longer than chords).
    travel = 1.05 * np.max(np.linalg.norm(points1 - points0, axis=-1), axis=-1)
    free = free_within(world, scene, footprint_of(js0, tip0, geometry), travel)
    new_pose = np.where(free[:, None], target, pose)
    new_joints = np.where(free[:, None], phi, joints)
    contacts: list[Contact | None] = [None] * pose.shape[0]
    for k in np.flatnonzero(~free):  # near something: checked sub-steps, robot by robot
        n = max(1, math.ceil(float(travel[k]) / check_step))
        for i in range(1, n + 1):
            s = i / n
            p = pose[k] + s * (target[k] - pose[k])
            ph = phi[k] + s * (phi[k] - phi[k])  # Simulator's interpolation, to the same bits
            contact = world.contact(footprint(p, ph, geometry))
            if contact is not None:
                contacts[k] = contact
                break
            new_pose[k], new_joints[k] = p, ph
    return new_pose, new_joints, contacts


def _ray_hits(origins: Array, dirs: Array, a: Array, b: Array) -> Array:
    """``ray_segment_hits`` for K origins ``[K, 2]`` with their own rays ``[K, R, 2]``: distance
    to segments ``a-b`` ``[E, 2]``, inf if missed, ``[K, R, E]``."""
    e = b - a
    d = dirs[:, :, None, :]  # [K, R, 1, 2]
    denom = d[..., 0] * e[:, 1] - d[..., 1] * e[:, 0]  # [K, R, E]
    rel = a[None, None, :, :] - origins[:, None, None, :]  # [K, 1, E, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (rel[..., 0] * e[:, 1] - rel[..., 1] * e[:, 0]) / denom
        s = (rel[..., 0] * d[..., 1] - rel[..., 1] * d[..., 0]) / denom
    ok = (np.abs(denom) > EPS) & (t >= 0) & (s >= 0) & (s <= 1)
    return np.where(ok, t, np.inf)


def _obstacle_hits(scene: Scene, origins: Array, dirs: Array) -> Array:
    """Distance along each ray to each obstacle (inf if missed, 0 from inside), ``[K, R, N]``,
    as ``Scene.ray_cast`` gives it for one origin."""
    out = np.empty((*dirs.shape[:2], scene.count))
    if scene.circle_index.size:
        rel = origins[:, None, :] - scene.centres  # [K, Nc, 2]
        bq = np.einsum("krd,kcd->krc", dirs, rel)
        cq = np.einsum("kcd,kcd->kc", rel, rel)[:, None, :] - scene.radii**2
        disc = bq * bq - cq
        root = np.sqrt(np.maximum(disc, 0.0))
        near, far = -bq - root, -bq + root
        t = np.where(near >= 0, near, np.where(far >= 0, 0.0, np.inf))
        out[..., scene.circle_index] = np.where(disc >= 0, t, np.inf)
    if scene.polygon_index.size:
        hits = _ray_hits(origins, dirs, scene.edge_a, scene.edge_b)  # [K, R, E]
        first = np.minimum.reduceat(hits, scene.first_edge, axis=-1)
        inside = scene.contains_polygon(origins)  # [K, Np]
        out[..., scene.polygon_index] = np.where(inside[:, None, :], 0.0, first)
    return out


def read_ranges(
    world: World, scene: Scene, sensors: SensorSuite, pose: Array
) -> tuple[Array, Mask]:
    """Noise-free range readings ``[K, S]`` of the suite's sensors at poses ``[K, 3]`` and whether
    each saw something within its range (an echo, the readings that take noise), as
    ``SensorSuite.read`` makes them. As in ``World.ray_cast``, a robot's rays meet only the walls
    and obstacles that could be within the sensors' reach (the rest would be hit beyond it,
    which reads as nothing within range); a robot near one is cast against all of them."""
    suite = sensors.range_sensors
    k = pose.shape[0]
    if not suite:
        return np.zeros((k, 0)), np.zeros((k, 0), dtype=bool)
    angles = [s.ray_angles() for s in suite]
    origins = head_tip(pose, sensors.geometry)
    forward = pose[:, 2] + math.pi
    dirs = unit_vectors(forward[:, None] + np.concatenate(angles)[None, :])  # [K, R, 2]
    reach = max(s.max_range for s in suite)
    nearest = np.full(dirs.shape[:2], np.inf)  # [K, R]
    b = world.bounds
    x, y = origins[:, 0], origins[:, 1]
    walls = np.flatnonzero(
        np.minimum(np.minimum(y - b.ymin, b.xmax - x), np.minimum(b.ymax - y, x - b.xmin)) <= reach
    )
    if walls.size:
        corners = b.corners()
        hits = _ray_hits(origins[walls], dirs[walls], corners, np.roll(corners, -1, axis=0))
        nearest[walls] = hits.min(axis=-1)
    if scene.count:
        box = scene.boxes
        near = np.flatnonzero(
            (
                (box[:, 0] <= x[:, None] + reach)
                & (box[:, 2] >= x[:, None] - reach)
                & (box[:, 1] <= y[:, None] + reach)
                & (box[:, 3] >= y[:, None] - reach)
            ).any(axis=1)
        )
        if near.size:
            hits = _obstacle_hits(scene, origins[near], dirs[near]).min(axis=-1)
            nearest[near] = np.minimum(nearest[near], hits)
    starts = np.cumsum([0, *(a.size for a in angles)])
    per_sensor = np.minimum.reduceat(nearest, starts[:-1], axis=-1)  # [K, S]
    caps = np.array([s.max_range for s in suite])
    return np.minimum(per_sensor, caps), np.asarray(per_sensor <= caps)


def add_noise(
    sensors: SensorSuite,
    ranges: Array,
    echo: Mask,
    joints: Array,
    rngs: Sequence[np.random.Generator],
) -> tuple[Array, Array]:
    """Noisy readings of K robots from their noise-free ``ranges`` ``[K, S]`` and ``joints``
    ``[K, 3]``, robot k drawing from ``rngs[k]`` what ``SensorSuite.read`` draws, in its order
    (the ranges with an echo, then the joints): ``normal(0, σ)`` is ``σ·standard_normal()``."""
    suite = sensors.range_sensors
    stds = np.array([s.noise_std for s in suite]).reshape(len(suite))
    draws = echo & (stds > 0)  # [K, S]
    joint_draws = np.full((len(rngs), 3), sensors.joint_noise_std > 0)
    wanted = np.concatenate([draws, joint_draws], axis=1)
    counts = wanted.sum(axis=1).tolist()
    z = np.zeros(wanted.shape)
    # Row-major boolean indexing visits each robot's draws in order, robot after robot.
    z[wanted] = np.concatenate(
        [rng.standard_normal(n) for rng, n in zip(rngs, counts, strict=True)]
    )
    caps = np.nextafter(np.array([s.max_range for s in suite]), 0)
    noisy = np.clip(ranges + stds * z[:, : len(suite)], 0, caps)
    return np.where(draws, noisy, ranges), joints + sensors.joint_noise_std * z[:, len(suite) :]


def is_noisy(sensors: SensorSuite) -> bool:
    """Whether reading the suite draws random numbers."""
    return sensors.joint_noise_std > 0 or any(s.noise_std > 0 for s in sensors.range_sensors)

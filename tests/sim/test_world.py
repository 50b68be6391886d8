"""Collisions, ray casting, sensors and events of the stepping simulator."""

import math

import numpy as np
import pytest

from sim.controls import FixedShape, PeriodicGait
from sim.env import SnakeEnv
from sim.events import Deformation, SensorDropout
from sim.obstacles import Circle, obstacle_from_dict, rectangle, unit_vectors
from sim.sensors import RangeSensor, SensorSuite, range_ring
from sim.simulator import Simulator
from sim.world import WALL, Bounds, World, footprint

FORWARD = FixedShape.of([-1, 1, -1, 1], [0, 0, 0])  # head first, towards -x


def drive(sim: Simulator, control, seconds: float):
    results = []
    for _ in range(round(seconds / sim.dt)):
        results.append(sim.step(control))
    return results


def test_robot_driven_into_a_wall_stops_before_it() -> None:
    wall = rectangle(-2.0, 0.0, 0.1, 4.0)  # face at x = -1.95
    sim = Simulator(World(obstacles=(wall,)), dt=1.0)
    results = drive(sim, FORWARD, 60)
    contacts = [r for r in results if r.contact is not None]
    assert contacts and contacts[0].contact.obstacle == 0 and contacts[0].contact.part == 0
    fp = footprint(sim.pose, sim.joints)
    assert sim.pose[0] > -1.95  # never through
    assert float(wall.segment_clearance(fp.starts, fp.ends).min()) < 0.05 + fp.radii.max()
    assert sim.collisions == len(contacts)


def test_thin_obstacle_is_not_tunnelled_through_with_large_steps() -> None:
    sliver = rectangle(-1.0, 0.0, 0.01, 2.0)
    sim = Simulator(World(obstacles=(sliver,)), dt=5.0)  # 0.375 m per step
    drive(sim, FORWARD, 60)
    assert sim.pose[0] > -1.0 and sim.collisions > 0


def test_bounds_stop_the_robot() -> None:
    sim = Simulator(World(bounds=Bounds(-1.5, 2, -2, 2)), dt=1.0)
    results = drive(sim, FORWARD, 40)
    assert any(r.contact and r.contact.obstacle == WALL for r in results)
    assert sim.pose[0] > -1.5


def test_ray_casts_hit_the_nearest_obstacle_at_the_right_distance() -> None:
    world = World(
        bounds=Bounds(-10, 10, -10, 10),
        obstacles=(Circle(3.0, 0.0, 0.5), rectangle(6.0, 0.0, 1.0, 1.0), Circle(0.0, 4.0, 1.0)),
    )
    dirs = unit_vectors([0.0, math.pi / 2, math.pi, -math.pi / 2])
    dist, what = world.ray_cast(np.zeros(2), dirs, max_range=20.0)
    np.testing.assert_allclose(dist, [2.5, 3.0, 10.0, 10.0], atol=1e-9)
    assert list(what) == [0, 2, WALL, WALL]
    dist, what = world.ray_cast(np.zeros(2), dirs[:1], max_range=1.0)
    assert dist[0] == 1.0 and what[0] == -2  # nothing within range


def test_forward_ir_sees_an_obstacle_ahead() -> None:
    world = World(obstacles=(Circle(-1.0, 0.0, 0.2),))
    sim = Simulator(world, sensors=SensorSuite(range_sensors=(RangeSensor("ir", max_range=1.0),)))
    reading = sim.read()
    # head tip at x = -0.055, circle face at x = -0.8
    assert reading.ranges["ir"] == pytest.approx(0.745, abs=1e-9)
    assert reading.hits["ir"] == 0


def test_sensor_noise_is_seeded() -> None:
    world = World(obstacles=(Circle(-1.0, 0.0, 0.2),))
    suite = SensorSuite(range_sensors=range_ring(8, 2.0, noise_std=0.02), joint_noise_std=0.01)
    sim = Simulator(world, sensors=suite)
    a = [sim.reset(seed=3).ranges for _ in range(2)]
    assert a[0] == a[1]
    assert sim.reset(seed=4).ranges != a[0]


def test_deformation_forces_and_holds_the_joints() -> None:
    sim = Simulator(events=(Deformation(10.0, (0.5, -0.5, -0.1)),), dt=1.0)
    results = drive(sim, FixedShape.of([-0.38, -0.05, -0.42, 0.06], [0, 0, 0]), 30)
    fired = [e for r in results for e in r.events if e.kind == "deform"]
    assert len(fired) == 1 and fired[0].t == pytest.approx(10.0)
    np.testing.assert_allclose(results[-1].readings.joints, [0.5, -0.5, -0.1])
    np.testing.assert_allclose(results[5].readings.joints, [0, 0, 0])
    # the gait is ignored while deformed: joints stay held
    after = drive(sim, PeriodicGait.of([0, 0, 0, 0], [0, 1, 2]), 5)
    np.testing.assert_allclose(after[-1].joints, [0.5, -0.5, -0.1])


def test_sensor_dropout_reads_nan_for_its_duration() -> None:
    sim = Simulator(events=(SensorDropout(2.0, 3.0, ("ir",)),), dt=1.0)
    results = drive(sim, FORWARD, 8)
    readings = [r.readings.ranges["ir"] for r in results]
    assert [math.isnan(v) for v in readings] == [
        False,
        True,
        True,
        True,
        False,
        False,
        False,
        False,
    ]


def test_stepping_simulator_matches_the_batched_rollout_in_free_space() -> None:
    from sim.rollout import RolloutConfig, rollout

    control = PeriodicGait.of([-0.10, 0.53, -0.12, 0.50], [0.6, -0.5, -0.3])
    sim = Simulator(World(bounds=Bounds(-50, 50, -50, 50)), dt=1.0)
    drive(sim, control, 100)
    end = rollout(control, config=RolloutConfig()).end[0]
    np.testing.assert_allclose(sim.pose, end[:3], atol=1e-9)


def test_start_inside_an_obstacle_is_rejected() -> None:
    circle = obstacle_from_dict({"type": "circle", "x": 0.3, "y": 0, "radius": 0.2})
    sim = Simulator(World(obstacles=(circle,)))
    with pytest.raises(ValueError, match="pose"):
        sim.reset((0.0, 0.0, 0.0))


def test_env_is_reproducible_and_rewards_progress() -> None:
    def episode(seed: int) -> list[float]:
        env = SnakeEnv(
            goal=(-2.0, 0.0),
            simulator=Simulator(sensors=SensorSuite(range_sensors=range_ring(4, noise_std=0.05))),
        )
        obs, info = env.reset(seed=seed)
        assert obs.shape == (env.observation_size,)
        rewards, done = [], False
        while not done:
            obs, reward, terminated, truncated, info = env.step([-1, 1, -1, 1, 0, 0, 0])
            rewards.append(reward)
            done = terminated or truncated
        assert terminated and info["distance"] <= env.tolerance
        return [*rewards, *obs]

    assert episode(1) == episode(1)
    assert sum(episode(1)[:5]) > 0


SIDEWAYS_PLUS_Y = FixedShape.of([-1, -1, -1, -1], [0, 0, 0])  # straight body at ψ = 0 -> +y


@pytest.mark.parametrize(
    ("obstacle", "control", "part", "side"),
    [
        (rectangle(-2.0, 0.0, 0.1, 4.0), FORWARD, 0, "front"),  # head first into a wall
        (rectangle(0.45, 1.0, 4.0, 0.1), SIDEWAYS_PLUS_Y, None, "right"),  # facing -x, +y is right
        (rectangle(0.45, -1.0, 4.0, 0.1), FixedShape.of([1, 1, 1, 1], [0, 0, 0]), None, "left"),
        (rectangle(2.5, 0.0, 0.1, 4.0), FixedShape.of([1, -1, 1, -1], [0, 0, 0]), 4, "rear"),
    ],
)
def test_contact_reports_the_part_and_the_side_that_touched(obstacle, control, part, side) -> None:
    sim = Simulator(World(obstacles=(obstacle,)), dt=0.5)
    contact = next(r.contact for r in drive(sim, control, 80) if r.contact is not None)
    assert contact.side == side
    if part is not None:
        assert contact.part == part


def test_range_noise_never_turns_nothing_in_range_into_an_echo() -> None:
    sensors = SensorSuite(
        (RangeSensor("ir", 0.0, 0.8, math.radians(10), 3, 0.05), *range_ring(8, 1.0, 0.05))
    )
    sim = Simulator(World(bounds=Bounds(-10, 10, -10, 10)), sensors=sensors)
    for seed in range(20):
        reading = sim.reset(seed=seed)
        assert reading.ranges["ir"] == 0.8
        assert all(reading.ranges[f"ring{i}"] == 1.0 for i in range(8))
    wall = World(obstacles=(rectangle(-0.6, 0.0, 0.1, 4.0),))  # 0.495 m ahead of the head tip
    sim = Simulator(wall, sensors=sensors)
    values = [sim.reset(seed=s).ranges["ir"] for s in range(200)]
    assert 0.45 < float(np.mean(values)) < 0.54 and float(np.std(values)) > 0.02

"""The gymnasium face of the simulator: SnakeGymEnv passes check_env, SnakeVectorEnv equals K of them."""

from __future__ import annotations

import subprocess
import sys
import warnings
from pathlib import Path

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from gymnasium.vector import AutoresetMode

from sim.batch_step import overlaps, read_ranges, step_fixed_shapes
from sim.controls import FixedShape
from sim.env import DROPPED
from sim.events import Deformation, SensorDropout
from sim.gym_env import ENV_ID, SnakeGymEnv
from sim.obstacles import Circle, rectangle
from sim.scene import Scene
from sim.sensors import SensorSuite, range_ring
from sim.simulator import Simulator
from sim.vector_env import SnakeVectorEnv
from sim.world import WALL, Bounds, World, footprint

NORMALISE_HINT = "we recommend using a symmetric and normalized space"


def cluttered(
    noise: float = 0.02, events: tuple[SensorDropout, ...] = (), joint_noise: float = 0.0
) -> Simulator:
    """A small arena with a disc and a bar near the start, a ring of noisy range sensors."""
    obstacles = (Circle(-0.8, 0.0, 0.2), rectangle(0.5, -0.6, 2.0, 0.1))
    world = World(Bounds(-2.2, 2.2, -2.2, 2.2), obstacles)
    sensors = SensorSuite(range_ring(6, noise_std=noise), joint_noise_std=joint_noise)
    return Simulator(world, sensors=sensors, events=events)


def checker_warnings(env: gymnasium.Env[np.ndarray, np.ndarray]) -> list[str]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env)
    return [str(w.message) for w in caught]


@pytest.mark.parametrize(
    "kwargs",
    [
        {},
        {
            "goal": (-1.0, 0.5),
            "simulator": cluttered(events=(SensorDropout(1.0, 2.0, ("ring0",)),)),
        },
    ],
    ids=["default", "cluttered-with-dropout"],
)
def test_check_env_passes_and_only_suggests_normalised_actions(kwargs: dict[str, object]) -> None:
    env = gymnasium.make(f"sim.gym_env:{ENV_ID}", **kwargs)
    assert isinstance(env.unwrapped, SnakeGymEnv)
    found = checker_warnings(env.unwrapped)
    # The action space is in physical units (rad/s, rad) as the simulator takes them; the
    # checker's one remaining remark is its advice to normalise (RescaleAction does that).
    assert len(found) == 1 and NORMALISE_HINT in found[0], found
    rescaled = gymnasium.wrappers.RescaleAction(env.unwrapped, -1.0, 1.0)
    assert np.all(rescaled.action_space.low == -1.0) and np.all(rescaled.action_space.high == 1.0)


def test_spaces_are_the_simulator_limits() -> None:
    env = SnakeGymEnv(goal=(1.0, 2.0))
    g = env.core.simulator.geometry
    assert env.action_space.shape == (7,)
    assert np.allclose(env.action_space.high, [1, 1, 1, 1] + [g.joint_limit - 0.05] * 3)
    assert np.array_equal(env.action_space.low, -env.action_space.high)
    obs_space = env.observation_space
    assert obs_space.shape == (10,)  # pose 4, joints 3, goal 2, the forward IR
    assert obs_space.low[0] == -10.0 and obs_space.high[7] == 1.0 + 10.0  # goal dx = 1 - x
    assert obs_space.high[9] == 0.8  # the IR's range
    assert obs_space.dtype == np.float64 and env.action_space.dtype == np.float64


def test_seeded_resets_repeat_whole_episodes() -> None:
    def episodes(seed: int) -> list[np.ndarray]:
        env = SnakeGymEnv(goal=(-1.0, 0.5), max_steps=6, simulator=cluttered())
        env.action_space.seed(seed)
        out = [env.reset(seed=seed)[0]]
        for _ in range(3):  # a seeded episode, then unseeded ones drawing from np_random
            for _ in range(6):
                obs, *_ = env.step(env.action_space.sample())
                out.append(obs)
            out.append(env.reset()[0])
        return out

    first, again, other = episodes(5), episodes(5), episodes(6)
    assert all(np.array_equal(a, b) for a, b in zip(first, again, strict=True))
    assert not all(np.array_equal(a, b) for a, b in zip(first, other, strict=True))


def test_a_dropped_reading_is_inside_the_space() -> None:
    sim = cluttered(noise=0.0, events=(SensorDropout(0.5, 1.0, ("ring1",)),))
    env = SnakeGymEnv(goal=(-1.0, 0.5), simulator=sim)
    env.reset(seed=0)
    obs, *_ = env.step([-0.2, 0.2, -0.2, 0.2, 0, 0, 0])  # t = 0.5: ring1 drops out
    assert obs[10] == DROPPED and obs in env.observation_space
    obs, *_ = env.step([-0.2, 0.2, -0.2, 0.2, 0, 0, 0])
    obs, *_ = env.step([-0.2, 0.2, -0.2, 0.2, 0, 0, 0])  # t = 1.5: back
    assert 0.0 <= obs[10] <= 1.5


def test_render_draws_an_rgb_frame() -> None:
    env = gymnasium.make(ENV_ID, render_mode="rgb_array", simulator=cluttered())
    env.reset(seed=0)
    frame = env.render()
    assert isinstance(frame, np.ndarray) and frame.dtype == np.uint8 and frame.shape[2] == 3
    assert len(np.unique(frame.reshape(-1, 3), axis=0)) > 3  # background, obstacles, goal, body
    with pytest.raises(ValueError, match="render_mode"):
        SnakeGymEnv(render_mode="human")


def test_make_vec_builds_the_batched_env() -> None:
    envs = gymnasium.make_vec(ENV_ID, num_envs=4, vectorization_mode="vector_entry_point")
    assert isinstance(envs.unwrapped, SnakeVectorEnv)
    assert envs.num_envs == 4 and envs.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    single = SnakeGymEnv()
    assert envs.single_observation_space == single.observation_space
    assert envs.single_action_space == single.action_space
    assert envs.observation_space.shape == (4, 10) and envs.action_space.shape == (4, 7)
    obs, info = envs.reset(seed=0)
    assert obs in envs.observation_space and info["distance"].shape == (4,)


def test_vector_env_steps_like_single_envs_with_next_step_autoreset() -> None:
    k, kwargs = 8, {"goal": (-0.4, 0.0), "max_steps": 25, "tolerance": 0.1}
    venv = SnakeVectorEnv(k, simulator=cluttered(joint_noise=0.01), **kwargs)
    singles = [SnakeGymEnv(simulator=cluttered(joint_noise=0.01), **kwargs) for _ in range(k)]
    vobs, _ = venv.reset(seed=3)
    sobs = np.stack([env.reset(seed=3 + i)[0] for i, env in enumerate(singles)])
    assert np.array_equal(vobs, sobs)
    venv.action_space.seed(0)
    ended = np.zeros(k, dtype=bool)
    seen = {"goal": 0, "collision": 0, "truncated": 0, "autoreset": 0}
    for _ in range(150):
        actions = venv.action_space.sample()
        actions[:, :4] = np.sign(actions[:, :4])  # full screw speeds: episodes end often
        actions[:3] = [-1.0, 1.0, -1.0, 1.0, 0.0, 0.0, 0.0]  # head first to the goal
        vobs, vrew, vterm, vtrunc, vinfo = venv.step(actions)
        assert vobs in venv.observation_space
        for i, env in enumerate(singles):
            if ended[i]:  # NEXT_STEP: this step resets the sub-environment, action ignored
                obs, rew, term, trunc, hit = env.reset()[0], 0.0, False, False, False
                seen["autoreset"] += 1
            else:
                obs, rew, term, trunc, info = env.step(actions[i])
                hit = info["collision"] is not None
                seen["collision"] += hit
                seen["goal"] += term and not hit
            seen["truncated"] += trunc
            assert obs in env.observation_space
            assert np.allclose(vobs[i], obs, rtol=0, atol=1e-9)
            assert abs(vrew[i] - rew) <= 1e-9
            assert (vterm[i], vtrunc[i]) == (term, trunc)
            assert vinfo["collided"][i] == hit
            ended[i] = term or trunc
    assert all(n > 0 for n in seen.values()), seen


def test_vector_reset_mask_resets_only_those_envs() -> None:
    venv = SnakeVectorEnv(3)
    venv.reset(seed=0)
    for _ in range(3):
        obs, *_ = venv.step(np.tile([-1.0, 1.0, -1.0, 1.0, 0, 0, 0], (3, 1)))
    mask = np.array([False, True, False])
    again, info = venv.reset(options={"reset_mask": mask, "pose": [0.5, 0.0, 0.0]})
    assert np.array_equal(again[[0, 2]], obs[[0, 2]])
    assert again[1, 0] == 0.5 and list(info["_distance"]) == [False, True, False]


def test_vector_env_refuses_bad_input_naming_it() -> None:
    venv = SnakeVectorEnv(2)
    venv.reset(seed=0)
    with pytest.raises(ValueError, match="actions"):
        venv.step(np.zeros((3, 7)))
    with pytest.raises(ValueError, match="actions"):
        venv.step(np.full((2, 7), np.nan))
    with pytest.raises(ValueError, match="seed"):
        venv.reset(seed=[1, 2, 3])
    with pytest.raises(ValueError, match="pose"):
        SnakeVectorEnv(2, simulator=cluttered()).reset(options={"pose": [-0.8, 0.0, 0.0]})
    with pytest.raises(ValueError, match="events"):
        SnakeVectorEnv(2, simulator=Simulator(events=(Deformation(1.0, (0.3, 0.0, 0.0)),)))
    with pytest.raises(ValueError, match="num_envs"):
        SnakeVectorEnv(0)


def test_sim_env_imports_without_gymnasium() -> None:
    code = (
        "import sys; sys.modules['gymnasium'] = None\n"
        "from sim.env import SnakeEnv\n"
        "env = SnakeEnv(); obs, _ = env.reset(seed=0); print(env.step([0] * 7)[0].shape)\n"
    )
    root = Path(__file__).resolve().parents[2]
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=root
    )
    assert out.stdout.strip() == "(10,)"


def test_batched_step_moves_and_stops_each_robot_as_the_simulator_does() -> None:
    """Many robots scattered round the obstacles, one step each: the batched step gives every
    robot the pose, joints and contact the stepping simulator gives it alone."""
    sim = cluttered(noise=0.0)
    scene = Scene(sim.world.obstacles)
    rng = np.random.default_rng(7)
    pose = np.column_stack([rng.uniform(-1.5, 1.5, (300, 2)), rng.uniform(-np.pi, np.pi, 300)])
    joints = rng.uniform(-0.5, 0.5, (300, 3))
    free = ~overlaps(sim.world, scene, footprint(pose, joints, sim.geometry))
    pose, joints = pose[free], joints[free]
    theta, phi = rng.choice([-1.0, 1.0], (len(pose), 4)), rng.uniform(-1.0, 1.0, (len(pose), 3))
    sim.dt = 2.0  # long steps: many robots reach an obstacle within one
    moved, held, contacts = step_fixed_shapes(
        sim.world, scene, sim.geometry, pose, joints, theta, phi, sim.dt, sim.check_step
    )
    ranges, _ = read_ranges(sim.world, scene, sim.sensors, moved)
    stopped, walls = 0, 0
    for k in range(len(pose)):
        sim.reset(pose[k], joints[k])
        result = sim.step(FixedShape(theta[k : k + 1], phi[k : k + 1]))
        assert np.allclose(moved[k], result.pose, rtol=0, atol=1e-9)
        assert np.allclose(held[k], result.joints, rtol=0, atol=1e-12)
        assert contacts[k] == result.contact
        expected = [result.readings.ranges[s.name] for s in sim.sensors.range_sensors]
        assert np.allclose(ranges[k], expected, rtol=0, atol=1e-9)
        stopped += result.contact is not None
        walls += WALL in result.readings.hits.values()
    assert len(pose) > 200 and 20 < stopped < len(pose) - 20 and walls > 20


def test_vector_env_agrees_with_gymnasiums_own_sync_vector_env() -> None:
    """The declared autoreset mode is gymnasium's: SyncVectorEnv of single envs in NEXT_STEP mode
    gives the same batches, step after step."""
    kwargs = {"goal": (-0.4, 0.0), "max_steps": 10, "tolerance": 0.1}
    ours = SnakeVectorEnv(4, simulator=cluttered(), **kwargs)
    theirs = gymnasium.vector.SyncVectorEnv(
        [lambda: SnakeGymEnv(simulator=cluttered(), **kwargs) for _ in range(4)],
        autoreset_mode=AutoresetMode.NEXT_STEP,
    )
    assert np.array_equal(ours.reset(seed=11)[0], theirs.reset(seed=11)[0])
    ours.action_space.seed(1)
    resets = 0
    for _ in range(40):
        actions = ours.action_space.sample()
        mine, reference = ours.step(actions), theirs.step(actions)
        for got, want in zip(mine[:4], reference[:4], strict=True):
            assert np.allclose(got, want, rtol=0, atol=1e-9)
        resets += int(np.sum(mine[2] | mine[3]))
    assert resets > 4


def test_make_vec_sync_and_the_batched_env_agree_from_one_simulator_argument() -> None:
    """gymnasium hands every sub-environment the same keyword arguments: each must still step a
    robot of its own."""
    kwargs = {"goal": (-0.4, 0.0), "max_steps": 10, "simulator": cluttered()}
    sync = gymnasium.make_vec(ENV_ID, num_envs=3, vectorization_mode="sync", **kwargs)
    batched = gymnasium.make_vec(ENV_ID, num_envs=3, **kwargs)
    assert np.array_equal(sync.reset(seed=2)[0], batched.reset(seed=2)[0])
    batched.action_space.seed(2)
    for _ in range(15):
        actions = batched.action_space.sample()
        assert np.allclose(sync.step(actions)[0], batched.step(actions)[0], rtol=0, atol=1e-9)

"""``SnakeVectorEnv``: K snake-robot episodes stepped together as one ``gymnasium.vector.VectorEnv``.

Each sub-environment is the ``SnakeGymEnv`` of ``sim.gym_env`` (same spaces, rewards, ends and
seeding); the K robots move in one numpy step (``sim.batch_step``) instead of K simulator
calls. They share one world: walls and obstacles stop them and their range sensors see them,
as in ``SnakeGymEnv``. Scheduled events (body deformations, sensor dropouts) are not supported:
a simulator with events is refused; use ``SnakeGymEnv`` (or gymnasium's ``SyncVectorEnv`` of
them) for those.

Autoreset is ``NEXT_STEP``: the step after a sub-environment terminates or truncates resets it
(its action ignored), returning the reset observation with reward 0 and neither flag set.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from numpy.typing import ArrayLike, NDArray

from sim.batch_step import add_noise, is_noisy, overlaps, read_ranges, step_fixed_shapes
from sim.controls import as_batch, check_joint_angles, clamp_joints
from sim.env import COLLISION_PENALTY, SnakeEnv
from sim.gym_env import SEED_SPAN
from sim.robot import Array
from sim.scene import Scene
from sim.simulator import Simulator
from sim.world import footprint

Mask = NDArray[np.bool_]
Seeds = int | list[int | None] | None


def _per_env(value: ArrayLike, width: int, name: str, count: int) -> Array:
    """``value`` as ``[count, width]``: one row for every sub-environment or one row each."""
    rows = as_batch(value, width, name)
    if rows.shape[0] == 1:
        return np.repeat(rows, count, axis=0)
    if rows.shape[0] != count:
        raise ValueError(f"{name}: {rows.shape[0]} rows for {count} environments")
    return rows


class SnakeVectorEnv(VectorEnv[Array, Array, NDArray[Any]]):
    """``num_envs`` snake robots driving to ``goal``; the other arguments are ``SnakeGymEnv``'s."""

    metadata: dict[str, Any] = {  # noqa: RUF012
        "render_modes": [],
        "autoreset_mode": AutoresetMode.NEXT_STEP,
    }

    def __init__(
        self,
        num_envs: int = 8,
        goal: tuple[float, float] = (-2.0, -2.0),
        tolerance: float = 0.05,
        max_steps: int = 400,
        start: tuple[float, float, float] = (0.0, 0.0, 0.0),
        start_joints: tuple[float, float, float] = (0.0, 0.0, 0.0),
        simulator: Simulator | None = None,
    ) -> None:
        if num_envs < 1:
            raise ValueError("num_envs: must be at least 1")
        sim = simulator if simulator is not None else Simulator()
        if sim.events:
            raise ValueError(
                "simulator.events: the vector env has no scheduled events; use SnakeGymEnv"
            )
        self.template = SnakeEnv(goal, tolerance, max_steps, start, start_joints, sim)
        self.num_envs = num_envs
        low, high = self.template.observation_bounds()
        self.single_observation_space = spaces.Box(low, high, dtype=np.float64)
        self.action_low, self.action_high = self.template.action_low, self.template.action_high
        self.single_action_space = spaces.Box(self.action_low, self.action_high, dtype=np.float64)
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self.scene = Scene(sim.world.obstacles)
        self.goal = np.array(goal, dtype=float)
        self.pose = np.zeros((num_envs, 3))
        self.joints = np.zeros((num_envs, 3))
        self.t = np.zeros(num_envs)
        self.steps = np.zeros(num_envs, dtype=np.int64)
        self.obs = np.zeros((num_envs, low.size))
        self.rngs: list[np.random.Generator | None] = [None] * num_envs
        self.sensor_rngs = [np.random.default_rng(0) for _ in range(num_envs)]
        self.autoreset = np.zeros(num_envs, dtype=bool)

    @property
    def simulator(self) -> Simulator:
        return self.template.simulator

    # -- reset ------------------------------------------------------------------------------
    def _seeds(self, seed: Seeds) -> list[int | None]:
        """One seed per sub-environment: ``seed + i`` for an int (gymnasium's convention)."""
        if seed is None:
            return [None] * self.num_envs
        if isinstance(seed, int | np.integer):
            return [int(seed) + i for i in range(self.num_envs)]
        if len(seed) != self.num_envs:
            raise ValueError(f"seed: {len(seed)} seeds for {self.num_envs} environments")
        return list(seed)

    def reset(
        self, *, seed: Seeds = None, options: dict[str, Any] | None = None
    ) -> tuple[Array, dict[str, Any]]:
        """Reset every sub-environment (or those in ``options["reset_mask"]``); ``options`` may
        give ``pose`` and ``joints``, one row for all or one per sub-environment."""
        options = dict(options or {})
        mask = np.asarray(options.pop("reset_mask", np.ones(self.num_envs, dtype=bool)))
        if mask.shape != (self.num_envs,) or mask.dtype != np.bool_:
            raise ValueError(f"reset_mask: expected {self.num_envs} booleans")
        seeds = self._seeds(seed)
        pose = _per_env(options.get("pose", self.template.start), 3, "pose", self.num_envs)
        joints = _per_env(
            options.get("joints", self.template.start_joints), 3, "joints", self.num_envs
        )
        check_joint_angles(joints, self.simulator.geometry)
        self._reset(
            np.flatnonzero(mask), seeds, pose, clamp_joints(joints, self.simulator.geometry)
        )
        return self.obs.copy(), self._info(mask)

    def _reset(
        self, envs: NDArray[np.intp], seeds: list[int | None], pose: Array, joints: Array
    ) -> None:
        """Reset sub-environments ``envs`` to rows of ``pose`` and ``joints`` (``[K, 3]``)."""
        fp = footprint(pose[envs], joints[envs], self.simulator.geometry)
        if np.any(overlaps(self.simulator.world, self.scene, fp)):
            raise ValueError("pose: the robot's start footprint overlaps an obstacle or a wall")
        for i in envs:
            rng = self.rngs[i]
            if seeds[i] is not None or rng is None:
                rng = seeding.np_random(seeds[i])[0]
                self.rngs[i] = rng
            self.sensor_rngs[i] = np.random.default_rng(int(rng.integers(SEED_SPAN)))
        self.pose[envs], self.joints[envs] = pose[envs], joints[envs]
        self.t[envs], self.steps[envs] = 0.0, 0
        self.autoreset[envs] = False
        self._observe(envs)

    def _observe(self, envs: NDArray[np.intp]) -> None:
        """Read the sensors of sub-environments ``envs`` into their observation rows."""
        sensors = self.simulator.sensors
        pose, joints = self.pose[envs], self.joints[envs]
        ranges, echo = read_ranges(self.simulator.world, self.scene, sensors, pose)
        if is_noisy(sensors):  # each robot draws from its own stream, in the simulator's order
            rngs = [self.sensor_rngs[i] for i in envs]
            ranges, joints = add_noise(sensors, ranges, echo, joints, rngs)
        head = np.stack([pose[:, 0], pose[:, 1], np.cos(pose[:, 2]), np.sin(pose[:, 2])], -1)
        to_goal = self.goal - pose[:, :2]
        self.obs[envs] = np.concatenate([head, joints, to_goal, ranges], axis=-1)

    def _distance(self) -> Array:
        d: Array = np.hypot(self.pose[:, 0] - self.goal[0], self.pose[:, 1] - self.goal[1])
        return d

    def _info(self, mask: Mask) -> dict[str, Any]:
        """Per-key arrays with gymnasium's ``_key`` masks (which entries are meaningful)."""
        info: dict[str, Any] = {"distance": self._distance(), "t": self.t.copy()}
        for key in list(info):
            info[f"_{key}"] = mask.copy()
        return info

    # -- step -------------------------------------------------------------------------------
    def step(
        self, actions: ArrayLike
    ) -> tuple[Array, NDArray[Any], NDArray[Any], NDArray[Any], dict[str, Any]]:
        """Hold each row of ``actions`` ``[num_envs, 7]`` for one simulator step."""
        a = as_batch(actions, 7, "actions")
        if a.shape[0] != self.num_envs:
            raise ValueError(f"actions: expected shape [{self.num_envs}, 7], got {list(a.shape)}")
        a = np.clip(a, self.action_low, self.action_high)
        done = self.autoreset.copy()
        live = np.flatnonzero(~done)
        rewards = np.zeros(self.num_envs)
        terminated = np.zeros(self.num_envs, dtype=bool)
        truncated = np.zeros(self.num_envs, dtype=bool)
        collided = np.zeros(self.num_envs, dtype=bool)
        if done.any():  # NEXT_STEP autoreset, to the start as an unseeded reset() would
            starts = _per_env(self.template.start, 3, "start", self.num_envs)
            joints = _per_env(self.template.start_joints, 3, "start_joints", self.num_envs)
            joints = clamp_joints(joints, self.simulator.geometry)
            self._reset(np.flatnonzero(done), [None] * self.num_envs, starts, joints)
        if live.size:
            before = self._distance()[live]
            sim = self.simulator
            pose, joints, contacts = step_fixed_shapes(
                sim.world,
                self.scene,
                sim.geometry,
                self.pose[live],
                self.joints[live],
                a[live, :4],
                a[live, 4:],
                sim.dt,
                sim.check_step,
            )
            self.pose[live], self.joints[live] = pose, joints
            self.t[live] += sim.dt
            self.steps[live] += 1
            hit = np.array([c is not None for c in contacts])
            after = self._distance()[live]
            collided[live] = hit
            rewards[live] = before - after - np.where(hit, COLLISION_PENALTY, 0.0)
            terminated[live] = (after <= self.template.tolerance) | hit
            truncated[live] = ~terminated[live] & (self.steps[live] >= self.template.max_steps)
            self._observe(live)
        self.autoreset = terminated | truncated
        info = self._info(np.ones(self.num_envs, dtype=bool))
        info["collided"], info["_collided"] = collided, ~done
        return self.obs.copy(), rewards, terminated, truncated, info

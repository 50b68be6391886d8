"""``SnakeEnv`` as a real ``gymnasium.Env``, registered as ``screwsnake/Snake-v0``.

Importing this module needs gymnasium (the ``rl`` extra); ``sim.env`` stays usable without it.
``gymnasium.make("screwsnake/Snake-v0", goal=..., simulator=...)`` builds a ``SnakeGymEnv``;
``gymnasium.make_vec("screwsnake/Snake-v0", num_envs=K)`` the batched ``SnakeVectorEnv``.

Spaces, in physical units and float64 (the simulator's precision):

- action: the 4 screw speeds within ±``max_screw_speed`` rad/s and the 3 joint angles to hold
  within ±``max_joint_angle`` (the joint limit less the singular margin). ``check_env`` suggests
  a normalised action space; ``gymnasium.wrappers.RescaleAction(env, -1.0, 1.0)`` gives one.
- observation: ``[x, y, cos ψ, sin ψ, φ1, φ2, φ3, goal dx, goal dy, ranges...]`` bounded by the
  arena, the joint limit and each sensor's range (``SnakeEnv.observation_bounds``); a dropped-out
  reading, NaN in ``SnakeEnv``, reads ``DROPPED`` here so that every observation lies in the space.
"""

from __future__ import annotations

import copy
from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces
from numpy.typing import ArrayLike

from sim.env import DROPPED, SnakeEnv
from sim.obstacles import Circle
from sim.robot import Array
from sim.simulator import Simulator
from sim.world import footprint

ENV_ID = "screwsnake/Snake-v0"
SEED_SPAN = 2**63  # sensor-noise seeds are drawn from the env's np_random in [0, 2**63)
RENDER_PIXELS = 400  # side of the square rgb_array frame


def fill_dropped(obs: Array) -> Array:
    """The observation with dropped-out (NaN) readings as ``DROPPED``."""
    return np.where(np.isnan(obs), DROPPED, obs)


class SnakeGymEnv(gymnasium.Env[Array, Array]):
    """The snake robot driving to a goal: ``SnakeEnv`` with declared spaces and gymnasium seeding.

    ``reset(seed=s)`` seeds ``np_random``; every reset draws the sensor-noise seed from it, so a
    seeded episode and the unseeded ones after it repeat exactly. ``options`` may give the start
    ``pose`` ``[x, y, ψ]`` and ``joints`` ``[φ1, φ2, φ3]``. The env steps its own copy of
    ``simulator`` (``env.core.simulator``): gymnasium's ``make_vec(..., vectorization_mode="sync",
    simulator=sim)`` hands every sub-environment the same object.
    """

    metadata: dict[str, Any] = {"render_modes": ["rgb_array"], "render_fps": 2}  # noqa: RUF012

    def __init__(
        self,
        goal: tuple[float, float] = (-2.0, -2.0),
        tolerance: float = 0.05,
        max_steps: int = 400,
        start: tuple[float, float, float] = (0.0, 0.0, 0.0),
        start_joints: tuple[float, float, float] = (0.0, 0.0, 0.0),
        simulator: Simulator | None = None,
        render_mode: str | None = None,
    ) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode: must be one of {self.metadata['render_modes']}")
        sim = copy.deepcopy(simulator) if simulator is not None else Simulator()
        self.core = SnakeEnv(goal, tolerance, max_steps, start, start_joints, sim)
        self.render_mode = render_mode
        low, high = self.core.observation_bounds()
        self.observation_space = spaces.Box(low, high, dtype=np.float64)
        self.action_space = spaces.Box(
            self.core.action_low, self.core.action_high, dtype=np.float64
        )

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Array, dict[str, Any]]:
        """Start an episode: ``(observation, info)``."""
        super().reset(seed=seed)
        sensor_seed = int(self.np_random.integers(SEED_SPAN))
        obs, info = self.core.reset(seed=sensor_seed, options=options)
        return fill_dropped(obs), info

    def step(self, action: ArrayLike) -> tuple[Array, float, bool, bool, dict[str, Any]]:
        """Hold ``action`` for one simulator step: ``(obs, reward, terminated, truncated, info)``."""
        obs, reward, terminated, truncated, info = self.core.step(action)
        return fill_dropped(obs), float(reward), terminated, truncated, info

    def render(self) -> Array | None:
        """An RGB frame ``[H, W, 3]`` (uint8) of the arena, obstacles, goal and body, in
        ``rgb_array`` mode; ``None`` without a render mode."""
        if self.render_mode != "rgb_array":
            return None
        return draw_frame(self.core)


def draw_frame(core: SnakeEnv) -> Array:
    """The arena, its obstacles, the goal and the robot's footprint as an RGB array."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    sim = core.simulator
    b = sim.world.bounds
    fig = Figure(figsize=(4, 4), dpi=RENDER_PIXELS / 4)
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_axes((0, 0, 1, 1))
    ax.set_xlim(b.xmin, b.xmax)
    ax.set_ylim(b.ymin, b.ymax)
    ax.set_aspect("equal")
    ax.axis("off")
    for o in sim.world.obstacles:
        if isinstance(o, Circle):
            ax.add_patch(_circle((o.x, o.y), o.radius, "0.4"))
        else:
            ax.fill(o.vertices[:, 0], o.vertices[:, 1], color="0.4")
    ax.add_patch(_circle(core.goal, max(core.tolerance, 0.05), "tab:green"))
    fp = footprint(sim.pose, sim.joints, sim.geometry)
    for start, end, radius in zip(fp.starts, fp.ends, fp.radii, strict=True):
        for centre in (start, end):
            ax.add_patch(_circle(tuple(centre), float(radius), "tab:orange"))
        ax.plot([start[0], end[0]], [start[1], end[1]], color="tab:red", linewidth=1)
    canvas.draw()  # type: ignore[no-untyped-call]
    frame: Array = np.asarray(canvas.buffer_rgba())[..., :3].copy()  # type: ignore[no-untyped-call]
    return frame


def _circle(centre: tuple[float, float], radius: float, color: str) -> Any:
    from matplotlib.patches import Circle as Disc

    return Disc(centre, radius, color=color)


if ENV_ID not in gymnasium.registry:  # a re-import must not re-register (gymnasium warns)
    gymnasium.register(
        id=ENV_ID,
        entry_point="sim.gym_env:SnakeGymEnv",
        vector_entry_point="sim.vector_env:SnakeVectorEnv",
    )

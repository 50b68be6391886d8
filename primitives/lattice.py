"""Lattice primitives: learn a short translation or turn of the body centroid, retime it to run
near the screw-speed limit, and record where it really lands and what it sweeps.

A lattice primitive holds a fixed shape, so its body-frame twist is linear in the screw speeds
θ: scaling θ by s and the duration by 1/s keeps the continuous end pose. It is learned at a
slow nominal duration (|θ| about 0.5, far from the clamps), scaled so that max|θ| is about
``SPEED_TARGET`` with the duration rounded up to the executor's control tick, and, because the
Euler steps then differ, refined by the same learner at the final duration with a speed cap.
Its entry stores the rollout of exactly those parameters: ``end_pose`` and the ``swept`` poses.

The periodic gait (U3) has no constant twist, so it takes its own path (``learn_gait_lattice``):
its phases are the lattice set's (``Shape.phases``), so every motion starts in the same shape
φ(0) = A sin ϕ, and it runs whole gait cycles (2π/ω = 10.47 model s each), then holds that
shape to the end of its last control tick (``PeriodicGait.t_end``): it ends where the next one
starts, and motions compose. Only the four screw speeds are learned, under the speed cap, at
that final duration. Its ``swept`` poses carry the joints at each (``swept_joints``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from primitives.catalogue import PrimitiveSpec
from primitives.grounding import gait_duration
from primitives.learners import CMAES, PI2CMA, Learner, LearningResult, StopRule, make_learner
from primitives.learners.base import Progress
from primitives.library import Primitive, RolloutSettings
from primitives.params import ParameterSpace
from primitives.pose_task import LATTICE_DT, PoseTask, reference_motion
from primitives.shapes import shape_named
from sim.controls import GAIT_CYCLE, Control, PeriodicGait
from sim.robot import DEFAULT_GEOMETRY, Array, body_twist, head_tip, joint_positions, rotate
from sim.rollout import RolloutConfig, rollout

TICK = 0.25  # model s: the executor's control interval; durations are whole ticks
SPEED_TARGET = 0.8  # rad/s: largest screw speed of a stored lattice primitive
LATTICE_THRESHOLD = 0.003  # cost (m + 1 m/rad × rad): ≤ 3 mm and ≤ 0.17°
LATTICE_STOP = StopRule(threshold=LATTICE_THRESHOLD, max_updates=200)
NOMINAL_SPEED = 0.025  # m/s of the centroid while learning (min-norm |θ| ≈ 0.47)
NOMINAL_TURN_RATE = 0.1  # rad/s while learning (min-norm |θ| ≈ 0.45-0.56)
REFINE_SIGMA = 0.02  # exploration of the refinement: the retimed θ is already close
SWEEP_STEP = 0.02  # m: no body point moves further between two swept poses
SWEEP_TURN = math.radians(2.0)  # nor does the heading turn further
MAX_ATTEMPTS = 4


def nominal_duration(target: tuple[float, float, float]) -> float:
    """The slow learning horizon of a target, in whole ticks."""
    seconds = max(
        math.hypot(target[0], target[1]) / NOMINAL_SPEED, abs(target[2]) / NOMINAL_TURN_RATE
    )
    return max(TICK, math.ceil(seconds / TICK - 1e-9) * TICK)


def retime(theta: ArrayLike, duration: float) -> tuple[Array, float]:
    """Scale ``theta`` towards max|θ| = ``SPEED_TARGET`` with the duration rounded up to whole
    ticks, keeping speed × duration (hence the continuous motion) unchanged."""
    th = np.asarray(theta, dtype=float)
    peak = float(np.max(np.abs(th)))
    if peak == 0.0:
        return th, duration
    fast = max(TICK, math.ceil(duration * peak / SPEED_TARGET / TICK - 1e-9) * TICK)
    return th * (duration / fast), fast


def idle_direction(joints: Sequence[float]) -> Array:
    """The unit screw-speed vector that moves a fixed shape not at all (the screws fight each
    other; (1, −1, −1, 1)/2 for the straight shape): the null space of θ ↦ twist."""
    phi = np.broadcast_to(np.asarray(joints, dtype=float), (4, 3))
    twist_of_unit = body_twist(np.eye(4), phi)  # [4, 3]: row i is the twist of θ = e_i
    out: Array = np.linalg.svd(twist_of_unit.T)[2][-1]
    return out


def trim_idle(theta: ArrayLike, joints: Sequence[float]) -> Array:
    """``theta`` plus the multiple of the idle direction that minimises max|θ|: the same twist
    with the least peak screw speed, so retiming gives the shortest duration."""
    th = np.asarray(theta, dtype=float)
    n = idle_direction(joints)
    # max_i |θ_i + t n_i| is convex and piecewise linear in t: its minimum lies where two of
    # the lines ±(θ_i + t n_i) cross (or where one alone is zero).
    candidates = [0.0]
    for i in range(4):
        if abs(n[i]) > 1e-12:
            candidates.append(-th[i] / n[i])
        for j in range(i + 1, 4):
            for sign in (1.0, -1.0):
                den = n[i] - sign * n[j]
                if abs(den) > 1e-12:
                    candidates.append(-(th[i] - sign * th[j]) / den)
    best = min(candidates, key=lambda t: (float(np.max(np.abs(th + t * n))), abs(t)))
    out: Array = th + best * n
    return out


def quiet(learner: Learner) -> Learner:
    """The learner with small initial exploration, for refining parameters that are close
    (the paper's PI² already explores by its cost-dependent schedule)."""
    if isinstance(learner, PI2CMA | CMAES):
        return dataclasses.replace(learner, sigma0=REFINE_SIGMA)
    return learner


def _learn(
    learner: Learner,
    task: PoseTask,
    seed: int,
    stop: StopRule,
    initial: Array | None = None,
    progress: Progress | None = None,
) -> LearningResult:
    result = None
    for attempt in range(MAX_ATTEMPTS):  # a seed that does not converge is followed by the next
        result = learner.learn(task, seed + 1000 * attempt, stop, initial, progress)
        if result.converged:
            break
    assert result is not None
    return result


def learn_lattice(
    spec: PrimitiveSpec,
    learner_name: str,
    seed: int,
    stop: StopRule,
    progress: Progress | None = None,
) -> Primitive:
    """Learn, retime, refine and record one lattice primitive (deterministic for a seed); a
    periodic shape's by ``learn_gait_lattice``. ``progress`` is called after every update of a
    fixed shape's learner (it may raise ``CancelledError`` to stop)."""
    target = (spec.goal[0], spec.goal[1], spec.turn)
    space = spec.space()
    if space.kind == "U3":
        return learn_gait_lattice(spec, learner_name, seed, stop)
    if space.kind != "U1":  # retiming and trimming rely on a constant twist
        raise ValueError(f"{spec.id}: lattice primitives need a fixed shape, not {spec.shape!r}")
    learner = make_learner(learner_name)
    slow = nominal_duration(target)
    first = _learn(
        learner,
        PoseTask(target, space, config=RolloutConfig(slow, LATTICE_DT)),
        seed,
        stop,
        progress=progress,
    )
    theta, duration = retime(trim_idle(first.params, space.joints), slow)
    capped = dataclasses.replace(space, speed_limit=SPEED_TARGET)
    task = PoseTask(target, capped, config=RolloutConfig(duration, LATTICE_DT))
    cost = float(task.costs(theta[None, :])[0])
    results = [first]
    if cost >= stop.threshold:
        results.append(_learn(quiet(learner), task, seed, stop, theta, progress))
        theta, cost = np.asarray(results[-1].params), results[-1].cost
    states = rollout(space.control(theta), config=task.config).states[0]
    settings = {**first.settings, "nominal_duration": slow, "refined": len(results) > 1}
    kept = sweep_indices(states[:, :3], space.joints)
    timing = RolloutSettings(duration=duration, dt=LATTICE_DT)
    return _record(
        spec,
        theta,
        cost,
        results,
        settings,
        states,
        kept,
        rollout=timing,
        space="U1",
        joints=space.joints,
    )


@dataclass(frozen=True)
class GaitSpace(ParameterSpace):
    """U3 with the phases fixed (a lattice set's) and the gait stopped after ``gait_end``
    model seconds: the four screw speeds are the parameters."""

    phases: tuple[float, float, float] = (0.0, 0.0, 0.0)
    gait_end: float = math.inf

    @property
    def size(self) -> int:
        return 4

    def control(self, params: ArrayLike) -> Control:
        p = np.atleast_2d(np.asarray(params, dtype=float))
        if p.shape[-1] != 4:
            raise ValueError(f"params: expected 4 screw speeds, got {p.shape[-1]}")
        return PeriodicGait.of(p, self.phases, t_end=self.gait_end)


def gait_cycles(target: tuple[float, float, float]) -> int:
    """Whole gait cycles a target takes: as many as its slow learning horizon needs (one for
    every lattice target of the catalogue)."""
    return max(1, math.ceil(nominal_duration(target) / GAIT_CYCLE - 1e-9))


def learn_gait_lattice(
    spec: PrimitiveSpec, learner_name: str, seed: int, stop: StopRule
) -> Primitive:
    """Learn and record one lattice primitive of a periodic shape: the screw speeds that carry
    the centroid to the target in whole gait cycles from the shape's lattice phases."""
    target = (spec.goal[0], spec.goal[1], spec.turn)
    phases = shape_named(spec.shape).phases
    if phases is None:
        raise ValueError(f"{spec.id}: shape {spec.shape!r} has no lattice gait phases")
    cycles = gait_cycles(target)
    space = GaitSpace("U3", speed_limit=SPEED_TARGET, phases=phases, gait_end=cycles * GAIT_CYCLE)
    task = PoseTask(target, space, config=RolloutConfig(gait_duration(cycles), LATTICE_DT))
    result = _learn(make_learner(learner_name), task, seed, stop)
    theta = np.asarray(result.params, dtype=float)
    states = rollout(space.control(theta), config=task.config).states[0]
    kept = sweep_indices(states[:, :3], states[:, 3:6])
    return _record(
        spec,
        theta,
        result.cost,
        [result],
        {**result.settings, "gait_cycles": cycles},
        states,
        kept,
        rollout=RolloutSettings(duration=task.config.duration, dt=LATTICE_DT),
        space="U3",
        phases=phases,
        cycles=cycles,
        swept_joints=[(float(j[0]), float(j[1]), float(j[2])) for j in states[kept, 3:6]],
    )


def _record(
    spec: PrimitiveSpec,
    theta: Array,
    cost: float,
    results: Sequence[LearningResult],
    settings: dict[str, Any],
    states: Array,
    kept: Sequence[int],
    **body: Any,
) -> Primitive:
    """The entry of a lattice primitive learned by ``results`` (the first's learner and seed
    name it), from the rollout ``states`` of its parameters ``theta``: where it lands, the
    ``kept`` states as its swept poses; ``body``: its rollout, space and shape fields."""
    end = states[-1, :3]
    first = results[0]
    return Primitive(
        id=spec.id,
        label=None,
        shape=spec.shape,
        theta=tuple(float(v) for v in theta),  # type: ignore[arg-type]
        goal=spec.goal,
        end=(float(end[0]), float(end[1])),
        cost=cost,
        learner=first.learner,
        settings=settings,
        seed=first.seed,
        updates=sum(r.updates for r in results),
        rollouts=sum(r.rollouts for r in results),
        curve=[round(c, 6) for r in results for c in r.curve],
        family="lattice",
        reference="centroid",
        turn=spec.turn,
        end_pose=(float(end[0]), float(end[1]), float(end[2])),
        swept=[(float(p[0]), float(p[1]), float(p[2])) for p in states[kept, :3]],
        **body,
    )


def body_points(poses: Array, joints: ArrayLike) -> Array:
    """The footprint's segment ends (head tip, tracked point, joints, tail) ``[N, 6, 2]`` for
    one shape ``[3]`` or one per pose ``[N, 3]``."""
    phi = np.broadcast_to(np.asarray(joints, dtype=float), (len(poses), 3))
    tip = head_tip(poses, DEFAULT_GEOMETRY)[:, None, :]
    return np.concatenate([tip, joint_positions(poses, phi)], axis=1)


def sweep(poses: Array, joints: ArrayLike) -> Array:
    """The poses ``sweep_indices`` keeps, ``[M, 3]``."""
    return np.asarray(poses[sweep_indices(poses, joints)])


def sweep_indices(poses: Array, joints: ArrayLike) -> list[int]:
    """Indices of a subset of ``poses`` ``[N, 3]`` (first and last kept) such that between
    consecutive kept poses no body point moves more than ``SWEEP_STEP`` and ψ turns at most
    ``SWEEP_TURN`` (unless one Euler step alone does); ``joints``: the shape ``[3]``, or each
    pose's ``[N, 3]``. Each segment of the body stays straight, so the largest displacement
    of any body point lies at a segment end of the footprint.
    """
    points = body_points(poses, joints)

    def too_far(i: int, j: int) -> bool:
        moved = float(np.max(np.linalg.norm(points[j] - points[i], axis=-1)))
        return moved > SWEEP_STEP or abs(poses[j, 2] - poses[i, 2]) > SWEEP_TURN

    kept = [0]
    for i in range(1, len(poses)):
        if too_far(kept[-1], i):
            if i - 1 > kept[-1]:
                kept.append(i - 1)
            if too_far(kept[-1], i):
                kept.append(i)
    if kept[-1] != len(poses) - 1:
        kept.append(len(poses) - 1)
    return kept


# -- helpers for planners: everything from the entry ---------------------------------------
def compose(pose: ArrayLike, delta: ArrayLike) -> Array:
    """``pose`` ⊕ ``delta``: the world pose reached by a start-frame displacement ``[..., 3]``."""
    p = np.asarray(pose, dtype=float)
    d = np.asarray(delta, dtype=float)
    xy = p[..., :2] + rotate(d[..., :2], p[..., 2] + np.zeros(d.shape[:-1]))
    return np.concatenate([xy, (p[..., 2] + d[..., 2])[..., None]], axis=-1)


def world_swept(entry: Primitive, pose: ArrayLike) -> Array:
    """The entry's swept tracked-point poses ``[M, 3]`` in the world, started from ``pose``."""
    return compose(pose, np.asarray(entry.swept, dtype=float))


def centroid_motion(entry: Primitive) -> Array:
    """Where the entry really moves its centroid (start frame) and its Δψ, ``[3]``."""
    if entry.end_pose is None:
        raise ValueError(f"{entry.id}: no end_pose (not a lattice primitive)")
    joints = np.asarray(entry.rest_joints, dtype=float)
    end = np.concatenate([np.asarray(entry.end_pose), joints])[None, :]
    out: Array = reference_motion(end, joints[None, :], "centroid")[0]
    return out

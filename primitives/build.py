"""Learn many primitives through an executor and assemble them into a library, deterministically.

Paper and lattice specs go through the same jobs; a lattice spec is learned by
primitives/lattice.py with its own, tighter stop rule.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from importlib.metadata import PackageNotFoundError, version

import numpy as np

from primitives.catalogue import PrimitiveSpec
from primitives.executors import Executor, SerialExecutor
from primitives.lattice import LATTICE_STOP, learn_lattice
from primitives.learners import StopRule, make_learner
from primitives.library import Library, Primitive
from primitives.task import LearningTask

BUILD_THRESHOLD = 0.02  # metres: tighter than the 5 cm acceptance so entries have margin
MAX_ATTEMPTS = 4  # a seed that does not converge is followed by the next one


def code_version() -> str:
    try:
        return version("screwsnake")
    except PackageNotFoundError:  # pragma: no cover - running from a plain checkout
        return "0+unknown"


@dataclass(frozen=True)
class BuildJob:
    """Everything one worker needs (picklable): the spec, learner, seed and stop rule."""

    spec: PrimitiveSpec
    learner: str
    seed: int
    stop: StopRule


def learn_primitive(job: BuildJob) -> Primitive:
    """Learn one primitive; retries with the following seeds until it converges."""
    if job.spec.family == "lattice":
        return learn_lattice(job.spec, job.learner, job.seed, job.stop)
    space = job.spec.space()
    task = LearningTask(job.spec.goal, space)
    learner = make_learner(job.learner)
    result = None
    for attempt in range(MAX_ATTEMPTS):
        result = learner.learn(task, job.seed + 1000 * attempt, job.stop)
        if result.converged:
            break
    assert result is not None
    theta, joints, phases = space.split(result.params)
    end = task.end_points(np.asarray(result.params)[None, :])[0]
    return Primitive(
        id=job.spec.id,
        label=job.spec.label,
        shape=job.spec.shape,
        space="U3" if space.kind == "U3" else "U1",
        theta=tuple(theta),  # type: ignore[arg-type]
        joints=tuple(joints) if joints else None,  # type: ignore[arg-type]
        phases=tuple(phases) if phases else None,  # type: ignore[arg-type]
        goal=job.spec.goal,
        end=(float(end[0]), float(end[1])),
        cost=result.cost,
        learner=result.learner,
        settings=result.settings,
        seed=result.seed,
        updates=result.updates,
        rollouts=result.rollouts,
        curve=[round(c, 6) for c in result.curve],
    )


def build_library(
    specs: Sequence[PrimitiveSpec],
    learner: str = "pi2",
    seed: int = 0,
    executor: Executor | None = None,
    stop: StopRule | None = None,
    done: Callable[[int], None] | None = None,
    lattice_stop: StopRule | None = None,
) -> Library:
    """Learn every spec (seed ``seed + index``) and return the library in spec order.

    ``stop`` applies to paper specs, ``lattice_stop`` (default: 3 mm / 0.17°) to lattice specs.
    """
    make_learner(learner)  # fail fast on an unknown name
    rule = stop or StopRule(threshold=BUILD_THRESHOLD, max_updates=200)
    fine = lattice_stop or LATTICE_STOP
    jobs = [
        BuildJob(spec, learner, seed + i, fine if spec.family == "lattice" else rule)
        for i, spec in enumerate(specs)
    ]
    entries = (executor or SerialExecutor()).map(learn_primitive, jobs, done)
    return Library(entries, code_version())

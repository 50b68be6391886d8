"""Learn the lattice primitives of a fixed body shape the library lacks, on the spot.

The set is the bundled library's lattice catalogue for that shape (primitives/catalogue.py:
eight translations at 0.05 m and eight at 0.25 m, six turns in place), each learned by
primitives/lattice.py on the batched simulator's rollouts with the project's fastest learner
(PI²-CMA, bench/learning.py Part 5) and the library build's own stop rule (``LATTICE_STOP``,
3 mm + 1 m/rad). The shape is named by its rounded joints (``primitives.shapes.learned_name``)
and primitive ``i`` is learned from ``shape_seed(name) + i``: the same joints give the same
entries in any process, on any executor.

A motion that does not reach the bar in its attempts is left out and named (some shapes cannot
make some motions); the planner plans with the rest. Learning checks a cancel callback and a wall
budget after every learner update (milliseconds apart), so either stops it at once.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from primitives.catalogue import lattice_specs
from primitives.lattice import LATTICE_STOP, learn_lattice
from primitives.learners import CancelledError, UpdateRecord
from primitives.library import Primitive
from primitives.shapes import learned_name, shape_named, shape_seed

DEFAULT_LEARNER = "pi2-cma"
DEFAULT_BUDGET = 30.0  # wall seconds for a whole set (bench/learning.py: about 0.3 s on one core)

Cancelled = Callable[[], bool]
Progress = Callable[[int, int], None]  # (primitives done, primitives in the set)


class LearningStopped(Exception):
    """Learning a shape stopped before the set was done (the message says why)."""

    def __init__(self, shape: str, reason: str, done: int, total: int) -> None:
        super().__init__(f"shape {shape}: {reason} ({done} of {total} primitives learned)")
        self.shape, self.reason, self.done, self.total = shape, reason, done, total


class LearningCancelled(LearningStopped):
    """The cancel callback said stop."""


class LearningOverBudget(LearningStopped):
    """The wall budget ran out."""


@dataclass(frozen=True)
class LearnedShape:
    """A shape's learned lattice set: the entries that reached the bar, the motions that did
    not (spec ids), and what it took."""

    shape: str
    joints: tuple[float, float, float]
    entries: tuple[Primitive, ...]
    failed: tuple[str, ...]
    rollouts: int
    wall: float  # seconds
    seed: int
    learner: str

    def summary(self) -> dict[str, Any]:
        """What the ``learned`` event and the learning job report."""
        return {
            "shape": self.shape,
            "joints": list(self.joints),
            "primitives": len(self.entries),
            "failed": list(self.failed),
            "rollouts": self.rollouts,
            "wall_ms": round(self.wall * 1e3, 1),
            "seed": self.seed,
            "learner": self.learner,
        }


def learn_shape(
    joints: Sequence[float],
    learner: str = DEFAULT_LEARNER,
    budget: float = DEFAULT_BUDGET,
    cancelled: Cancelled | None = None,
    progress: Progress | None = None,
) -> LearnedShape:
    """Learn the lattice set of the fixed shape ``joints`` (rounded to its name's steps).

    Raises ``LearningCancelled`` when ``cancelled()`` turns true and ``LearningOverBudget``
    past ``budget`` wall seconds, each within one learner update; ``progress(done, total)``
    is called after every primitive (and once with 0 before the first).
    """
    name = learned_name(joints)
    shape = shape_named(name)
    specs = lattice_specs((name,))
    seed = shape_seed(name)
    started = time.perf_counter()
    deadline = started + budget
    done = 0

    def check(_: UpdateRecord | None = None) -> None:
        if cancelled is not None and cancelled():
            raise CancelledError()
        if time.perf_counter() > deadline:
            raise TimeoutError()

    entries: list[Primitive] = []
    failed: list[str] = []
    rollouts = 0
    if progress is not None:
        progress(0, len(specs))
    try:
        for i, spec in enumerate(specs):
            check()
            entry = learn_lattice(spec, learner, seed + i, LATTICE_STOP, progress=check)
            rollouts += entry.rollouts
            if entry.cost < LATTICE_STOP.threshold:
                entries.append(entry)
            else:
                failed.append(spec.id)
            done = i + 1
            if progress is not None:
                progress(done, len(specs))
    except CancelledError:
        raise LearningCancelled(name, "cancelled", done, len(specs)) from None
    except TimeoutError:
        raise LearningOverBudget(
            name, f"not learned within the {budget:g} s wall budget", done, len(specs)
        ) from None
    return LearnedShape(
        name,
        shape.joints,
        tuple(entries),
        tuple(failed),
        rollouts,
        time.perf_counter() - started,
        seed,
        learner,
    )

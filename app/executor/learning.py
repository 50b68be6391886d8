"""Shapes the library lacks, learned in the mission: which lattice shape a body's joints run
on, and the learning itself, while the robot stands still.

A lattice planner may run a shape's motions only on joints within ``tolerance`` of that shape's
(``Library.lattice_covers``): further off, the recorded ends are not where the body goes. A body
without such a shape (the start shape, or a deformation) gets its own lattice set learned on the
spot (``primitives.shape_learning``), joins the mission's library as a new version, and the
mission plans on it. Model time stands still while it learns (no control tick runs); the wall
clock does not, and the mission's wall-clock limit counts it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

from primitives.coverage import LATTICE_TOLERANCE
from primitives.library import Library
from primitives.shape_learning import (
    DEFAULT_BUDGET,
    DEFAULT_LEARNER,
    Cancelled,
    LearnedShape,
    Progress,
    learn_shape,
)
from primitives.shapes import learned_name

ShapeLearner = Callable[[Sequence[float], "LearningSettings", Cancelled, Progress], LearnedShape]


@dataclass(frozen=True)
class LearningSettings:
    """How a mission learns a shape its library lacks."""

    budget: float = DEFAULT_BUDGET
    """wall seconds for the whole lattice set; past it the mission fails ``learning: ...``"""
    learner: str = DEFAULT_LEARNER
    """the learner (``primitives.learners``)"""
    tolerance: float = LATTICE_TOLERANCE
    """radians (max-abs) within which a lattice shape's motions serve other joints"""

    def __post_init__(self) -> None:
        if not self.budget > 0:
            raise ValueError("learning budget: must be positive (wall seconds)")
        if not 0 < self.tolerance <= 0.5:
            raise ValueError("learning tolerance: must lie within (0, 0.5] rad")


def learn_here(
    joints: Sequence[float], settings: LearningSettings, cancelled: Cancelled, progress: Progress
) -> LearnedShape:
    """Learn in this process (a mission's worker, the CLI)."""
    return learn_shape(joints, settings.learner, settings.budget, cancelled, progress)


def lattice_shape(
    library: Library, joints: Sequence[float], settings: LearningSettings
) -> tuple[str, bool]:
    """The shape whose lattice the body ``joints`` runs on, and whether it must be learned
    first (no lattice shape within the tolerance: then it is the joints' own learned shape)."""
    cover = library.lattice_covers(joints, settings.tolerance)
    if cover.shape is not None:
        return cover.shape, False
    return learned_name(joints), True


def learned_event(learned: LearnedShape, library: Library, tables: float) -> dict[str, object]:
    """The ``learned`` event's fields: ``wall_ms`` counts the learning and the new lattice's
    motion tables (``tables`` seconds, also on their own); the library version is the new
    one's, shortened as the service reports versions."""
    summary = learned.summary()
    wall = round((learned.wall + tables) * 1e3, 1)
    return {
        **summary,
        "wall_ms": wall,
        "tables_ms": round(tables * 1e3, 1),
        "library": library.version[:12],
    }

"""Learners behind one interface: the paper's PI², PI²-CMA and CMA-ES."""

from __future__ import annotations

from primitives.learners.base import (
    CancelledError,
    Learner,
    LearningResult,
    StopRule,
    UpdateRecord,
)
from primitives.learners.cmaes import CMAES
from primitives.learners.pi2 import PI2
from primitives.learners.pi2_cma import PI2CMA

LEARNERS: dict[str, type[PI2] | type[PI2CMA] | type[CMAES]] = {
    "pi2": PI2,
    "pi2-cma": PI2CMA,
    "cmaes": CMAES,
}


def make_learner(name: str) -> Learner:
    try:
        return LEARNERS[name]()
    except KeyError:
        raise ValueError(f"learner: unknown {name!r}; known: {', '.join(LEARNERS)}") from None


__all__ = [
    "CMAES",
    "LEARNERS",
    "PI2",
    "PI2CMA",
    "CancelledError",
    "Learner",
    "LearningResult",
    "StopRule",
    "UpdateRecord",
    "make_learner",
]

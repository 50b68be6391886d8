"""Typed replanning triggers and the record each replan leaves (``docs/navigation.md``)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from domain.knowledge import Goal
from sim.obstacles import Obstacle


@dataclass(frozen=True)
class ObstacleSensed:
    """A precondition broke: an obstacle was sensed on or near the next edge."""

    obstacle: Obstacle
    kind: str = "obstacle_sensed"

    def detail(self) -> dict[str, Any]:
        return {"obstacle": self.obstacle.to_dict()}


@dataclass(frozen=True)
class ShapeChanged:
    """The joint-angle sensors disagree with the commanded shape (a deformation)."""

    shape: str
    joints: tuple[float, float, float] = (0.0, 0.0, 0.0)
    kind: str = "shape_changed"

    def detail(self) -> dict[str, Any]:
        return {"shape": self.shape, "joints": list(self.joints)}


@dataclass(frozen=True)
class NoProgress:
    """The current action failed or made no progress towards its target."""

    action: str
    reason: str = "no progress"
    kind: str = "no_progress"

    def detail(self) -> dict[str, Any]:
        return {"action": self.action, "reason": self.reason}


@dataclass(frozen=True)
class GoalsChanged:
    """A goal was added or removed (or reached: the remaining goals changed)."""

    added: tuple[Goal, ...] = ()
    removed: tuple[Goal, ...] = ()
    kind: str = "goals_changed"

    def detail(self) -> dict[str, Any]:
        return {
            "added": [(g.x, g.y) for g in self.added],
            "removed": [(g.x, g.y) for g in self.removed],
        }


@dataclass(frozen=True)
class ObstacleAdded:
    """An operator added a known obstacle to the world model (a live update)."""

    obstacle: Obstacle
    kind: str = "obstacle_added"

    def detail(self) -> dict[str, Any]:
        return {"obstacle": self.obstacle.to_dict()}


@dataclass(frozen=True)
class Resumed:
    """A paused mission resumed: the world may have changed while it stood still."""

    paused_at: float  # model seconds
    kind: str = "resumed"

    def detail(self) -> dict[str, Any]:
        return {"paused_at": self.paused_at}


@dataclass(frozen=True)
class Timeout:
    """An action ran past its time budget."""

    action: str
    kind: str = "timeout"

    def detail(self) -> dict[str, Any]:
        return {"action": self.action}


@dataclass(frozen=True)
class Initial:
    """The first plan of a goal (not a replan, but recorded the same way)."""

    kind: str = "initial"

    def detail(self) -> dict[str, Any]:
        return {}


@dataclass(frozen=True)
class PathBlocked:
    """A precondition broke: the world model now occupies what a planned move sweeps."""

    action: str
    at: tuple[float, float]
    kind: str = "path_blocked"

    def detail(self) -> dict[str, Any]:
        return {"action": self.action, "at": list(self.at)}


@dataclass(frozen=True)
class Contact:
    """The contact sensor fired: a unit touched something (the world model now has it)."""

    part: int
    side: str
    at: tuple[float, float]
    kind: str = "contact"

    def detail(self) -> dict[str, Any]:
        return {"part": self.part, "side": self.side, "at": list(self.at)}


@dataclass(frozen=True)
class Recovered:
    """A recovery of the behaviour tree moved the robot (or cleared evidence): plan again."""

    recovery: str
    because: str = ""
    kind: str = "recovered"

    def detail(self) -> dict[str, Any]:
        return {"recovery": self.recovery, "because": self.because}


Trigger = (
    ObstacleSensed
    | ShapeChanged
    | NoProgress
    | GoalsChanged
    | ObstacleAdded
    | Resumed
    | Timeout
    | Initial
    | PathBlocked
    | Contact
    | Recovered
)


@dataclass(frozen=True)
class ReplanRecord:
    trigger: str
    detail: dict[str, Any]
    at: float  # model time
    latency_ms: float
    old: list[str] = field(default_factory=list)
    new: list[str] = field(default_factory=list)
    status: str = "solved"

    def to_dict(self) -> dict[str, Any]:
        return {
            "trigger": self.trigger,
            "detail": self.detail,
            "at": self.at,
            "latency_ms": round(self.latency_ms, 3),
            "old": self.old,
            "new": self.new,
            "status": self.status,
        }

"""Typed messages between a mission's worker process, the supervisor and the websocket hub.

Worker -> supervisor: what happened (stored, then broadcast, in order). Supervisor -> worker:
the next mission to run (a pool worker runs missions one after another) and live updates of the
running one. All are frozen dataclasses: picklable across processes and to Ray actors.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from app.missions.status import MissionStatus

Frame = dict[str, Any]  # a websocket frame (see app.api.frames for the protocol's schemas)


# -- worker -> supervisor -------------------------------------------------------------------------
@dataclass(frozen=True)
class Transition:
    """The mission entered a status (stored as a transition, broadcast as a status event)."""

    status: MissionStatus
    reason: str = ""
    state: dict[str, Any] | None = None


@dataclass(frozen=True)
class SaveState:
    """The mission's latest state, to store (not broadcast)."""

    state: dict[str, Any]


@dataclass(frozen=True)
class Publish:
    """A websocket frame to broadcast as it is (state and event frames)."""

    frame: Frame


@dataclass(frozen=True)
class Events:
    """Event frames to broadcast as they are, in order: those of a stretch of ticks, sent as
    one message (an obstacle sensed at most ticks would otherwise be a message per tick)."""

    frames: tuple[Frame, ...]


def frames_of(message: WorkerMessage) -> tuple[Frame, ...]:
    """The websocket frames a message carries as they are (a ``Publish``'s, an ``Events``')."""
    if isinstance(message, Publish):
        return (message.frame,)
    if isinstance(message, Events):
        return message.frames
    return ()


@dataclass(frozen=True)
class Replanned:
    """A replan's record (trigger, latency, old and new plan), before its new plan."""

    record: dict[str, Any]
    version: int
    t: float


@dataclass(frozen=True)
class PlanMade:
    """A plan version with its PDDL domain, what regenerates its problem (never the text:
    ``app.executor.plan_versions.render`` writes it when someone asks) and grounded actions."""

    version: int
    domain: str
    domain_pddl: str
    problem_source: bytes
    plan: list[str]
    actions: list[dict[str, Any]]


@dataclass(frozen=True)
class TrajectoryDone:
    """The mission's (thinned) trajectory and its world model's changes, sent once at the end
    (``app.service.world_history``)."""

    points: list[list[float]]
    world: list[dict[str, Any]] | None = None


@dataclass(frozen=True)
class Ended:
    """The terminal status; always the worker's last message."""

    status: MissionStatus
    reason: str
    state: dict[str, Any] | None = None


@dataclass(frozen=True)
class Learned:
    """The mission learned a shape's lattice set: stored once, as a new library version, for
    every later mission (``app.service.library``)."""

    shape: str
    entries: str  # the entries as a JSON list, as in the library file
    # The learned shapes of the library the mission now runs on, in its order (the store's,
    # then this one): the version its ``learned`` event names.
    shapes: tuple[str, ...]


WorkerMessage = (
    Transition
    | SaveState
    | Publish
    | Events
    | Replanned
    | PlanMade
    | TrajectoryDone
    | Learned
    | Ended
)


# -- supervisor -> worker (live updates) -------------------------------------------------------
@dataclass(frozen=True)
class AddGoal:
    x: float
    y: float
    tolerance: float
    index: int = -1  # the index the server answered (it is the next: the worker checks)
    kind: str = "add_goal"


@dataclass(frozen=True)
class RemoveGoal:
    index: int
    kind: str = "remove_goal"


@dataclass(frozen=True)
class AddObstacle:
    obstacle: dict[str, Any]  # as in a mission's `obstacles` (sim.obstacles.obstacle_from_dict)
    kind: str = "add_obstacle"


@dataclass(frozen=True)
class Pause:
    kind: str = "pause"


@dataclass(frozen=True)
class Resume:
    kind: str = "resume"


Update = AddGoal | RemoveGoal | AddObstacle | Pause | Resume


@dataclass(frozen=True)
class Job:
    """Run this mission next (a pool worker's inbox); the worker answers with its messages."""

    mission_id: str
    request: dict[str, Any]
    wall_limit: float
    # The stored maps the mission names (``app.missions.maps.StoredMap`` by id): the worker
    # validates the request with them, and reads no store.
    maps: dict[str, Any] = field(default_factory=dict)
    # The shapes learned so far (``app.service.library``: (shape, entries JSON) in the
    # stored order): the worker's library gains those it lacks, so no shape is learned twice.
    learned: tuple[tuple[str, str], ...] = ()
    learn_budget: float = 30.0  # wall seconds to learn a shape's lattice set


@dataclass(frozen=True)
class Addressed:
    """A live update for one mission: a worker drops updates meant for a mission it no longer
    runs (one sent just as that mission ended must not reach the next)."""

    mission_id: str
    update: Update

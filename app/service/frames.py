"""The frames a mission's websocket stream carries after its snapshot: one pydantic model per
frame type. The supervisor publishes these typed frames to the hub; the websocket sends them as
JSON; the AsyncAPI document (``app.api.frames``) is generated from them.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, TypeAdapter

from app.missions.status import MissionStatus


class PoseOut(BaseModel):
    """Where the robot is: its tracked point (the head), heading and joint angles."""

    x: float = Field(description="tracked point x, metres (world frame)")
    y: float = Field(description="tracked point y, metres (world frame)")
    psi: float = Field(description="heading ψ of the head, radians, counter-clockwise from +x")
    joints: list[float] = Field(description="the three joint angles φ1..φ3 as sensed, radians")


class Frame(BaseModel):
    model_config = ConfigDict(extra="forbid")


class LearningProgress(BaseModel):
    """How far learning the body's shape got (only while the mission is ``learning``)."""

    shape: str = Field(description="the learned shape's name (its joints, rounded)")
    done: int = Field(description="lattice primitives learned so far")
    total: int = Field(description="lattice primitives in the set (0 before the first)")


class StateFrame(Frame):
    """The robot's state (at most `SCREWSNAKE_WS_RATE` per second; a slow client gets the
    latest only)."""

    type: Literal["state"]
    t: float = Field(description="model seconds")
    pose: PoseOut = Field(description="tracked point (metres), heading and joints (radians)")
    action: str = Field(description="the plan action being executed (PDDL), or empty")
    grounding: dict[str, Any] = Field(description="how that action is run: primitive(s), method")
    sensors: dict[str, Any] = Field(description="range readings by sensor name, metres")
    tree: dict[str, Any] = Field(
        description="behaviour-tree snapshot: name, type, status, feedback, children"
    )
    shape: str = Field(description="the body shape the joints are classified as")
    learning: LearningProgress | None = Field(
        default=None,
        description="while learning the shape's lattice primitives: done / total (else null)",
    )


class EventFrame(Frame):
    """Something that happened in the mission, told apart by its ``kind``."""

    type: Literal["event"]


class TimedEvent(EventFrame):
    """An event at a model time."""

    t: float = Field(description="model seconds")


class StatusEvent(EventFrame):
    """The mission entered a status (also written to its transitions)."""

    kind: Literal["status"]
    status: MissionStatus = Field(description="the status entered")
    reason: str = Field(default="", description="why (a trigger kind, a failure, a request)")


class ReplanEvent(TimedEvent):
    """A replan happened: sent once, after the `replanning` status and before its `plan`."""

    kind: Literal["replan"]
    trigger: str = Field(description="the typed trigger's kind (see ReplanOut)")
    detail: dict[str, Any] = Field(description="the trigger's fields")
    latency_ms: float = Field(description="planning time, wall milliseconds")
    old: list[str] = Field(description="remaining steps of the replaced plan")
    new: list[str] = Field(description="the new plan's steps")
    status: str = Field(description="solved, or why no plan was found")
    version: int = Field(description="the plan version this replan made")


class DeformEvent(TimedEvent):
    """The joint sensors found the body in another shape than commanded."""

    kind: Literal["deform"]
    joints: list[float] = Field(description="the sensed joint angles, radians")
    shape: str = Field(description="the library shape they are classified as")
    coverage: dict[str, Any] | None = Field(
        default=None,
        description=(
            "how the library covers the sensed shape: kind (library | interpolated), shape, "
            "sources and weights of a blend, error (rad)"
        ),
    )


class LearnedEvent(TimedEvent):
    """The body's shape had no lattice shape within the tolerance: its lattice primitives
    were learned (the robot stood still; model time did not run) and joined the library."""

    kind: Literal["learned"]
    shape: str = Field(description="the learned shape's name (its joints, rounded)")
    joints: list[float] = Field(description="the joints it was learned for, radians")
    primitives: int = Field(description="lattice primitives learned (within the library's bar)")
    failed: list[str] = Field(description="motions that did not reach the bar: left out")
    rollouts: int = Field(description="simulator rollouts it took")
    wall_ms: float = Field(description="wall milliseconds it took, motion tables included")
    tables_ms: float = Field(description="of which the new lattice's motion tables")
    seed: int = Field(description="the seed, derived from the shape")
    learner: str = Field(description="the learner (pi2-cma)")
    library: str = Field(description="the library version the mission runs on from now on")


class ShapeChangeEvent(TimedEvent):
    """The plan or chain commanded another body shape (a shape change as an action)."""

    kind: Literal["shape_change"]
    shape: str = Field(description="the library shape the body takes")
    previous: str = Field(description="the shape it had")


class CollisionEvent(TimedEvent):
    """A bumper fired."""

    kind: Literal["collision"]
    part: int = Field(description="0 the head, 1..4 the screw units")
    side: str = Field(description="front, rear, left or right")
    at: list[float] | None = Field(default=None, description="where it was felt [x, y], metres")
    action: str | None = Field(
        default=None, description="the step running when it was felt (a plan's move, a recovery)"
    )


class GoalReachedEvent(TimedEvent):
    """A goal was reached."""

    kind: Literal["goal_reached"]
    goal: int = Field(description="the goal's index, as posted")
    error: float = Field(description="distance from the goal, metres")


class ObstacleSensedEvent(TimedEvent):
    """Range sensors marked new occupied cells in the world model."""

    kind: Literal["obstacle_sensed"]
    cells: int = Field(description="how many 0.05 m cells became occupied")


class DropoutEvent(TimedEvent):
    """Sensors went silent (a mission event)."""

    kind: Literal["dropout"]
    sensors: list[str] = Field(description="the silent sensors")
    duration: float = Field(description="for how long, model seconds")


class UpdateEvent(TimedEvent):
    """A live update (POST /missions/{id}/goals, /obstacles, /pause, /resume) took effect."""

    kind: Literal["update"]
    update: str = Field(description="add_goal, remove_goal, add_obstacle, pause or resume")
    detail: dict[str, Any] = Field(description="the update's fields (goal index, obstacle)")


class RecoveryEvent(TimedEvent):
    """A recovery of the behaviour tree started (after a contact or a failed plan)."""

    kind: Literal["recovery"]
    recovery: str = Field(description="back off, spin to sense, reshape or clear stale evidence")
    because: str = Field(description="the failure it answers (the contact, or the plan's reason)")
    moves: list[str] = Field(description="the library primitives (or 'wait') it runs, in order")


class RecoveryDoneEvent(TimedEvent):
    """A recovery ended; the plan is made again from where the robot stands."""

    kind: Literal["recovery_done"]
    recovery: str = Field(description="which recovery")
    outcome: str = Field(description="done, or stopped by a contact")


class PlanFrame(Frame):
    """A new plan version (the first, or after a replan)."""

    type: Literal["plan"]
    version: int = Field(description="plan version, 1 for the first")
    plan: list[str] = Field(description="the plan's steps (PDDL actions)")
    actions: list[dict[str, Any]] = Field(description="the steps with their grounding")


class EndFrame(Frame):
    """Always the last frame: the terminal status. The server closes the socket after it."""

    type: Literal["end"]
    status: MissionStatus = Field(description="succeeded, failed or cancelled")
    reason: str = Field(description="why it ended")


class ErrorFrame(Frame):
    """The client sent something that is not a ping, or the mission does not exist (then the
    socket closes with code 4404)."""

    type: Literal["error"]
    detail: str = Field(description="what was wrong")
    status: int | None = Field(default=None, description="404 when the mission does not exist")


class PongFrame(Frame):
    """The answer to a ping."""

    type: Literal["pong"]


class PingFrame(Frame):
    """The one message a client may send."""

    type: Literal["ping"]


EVENTS = (
    StatusEvent,
    ReplanEvent,
    DeformEvent,
    LearnedEvent,
    ShapeChangeEvent,
    CollisionEvent,
    GoalReachedEvent,
    ObstacleSensedEvent,
    DropoutEvent,
    UpdateEvent,
)
Event = Annotated[
    StatusEvent
    | ReplanEvent
    | DeformEvent
    | LearnedEvent
    | ShapeChangeEvent
    | CollisionEvent
    | GoalReachedEvent
    | ObstacleSensedEvent
    | DropoutEvent
    | UpdateEvent
    | RecoveryEvent
    | RecoveryDoneEvent,
    Field(discriminator="kind"),
]
StreamFrame = (
    StateFrame
    | StatusEvent
    | ReplanEvent
    | DeformEvent
    | LearnedEvent
    | ShapeChangeEvent
    | CollisionEvent
    | GoalReachedEvent
    | ObstacleSensedEvent
    | DropoutEvent
    | UpdateEvent
    | RecoveryEvent
    | RecoveryDoneEvent
    | PlanFrame
    | EndFrame
)
_EVENT: TypeAdapter[Event] = TypeAdapter(Event)


def parse_frame(data: dict[str, Any]) -> StreamFrame:
    """A frame as sent by a worker, as its model (pydantic's ValidationError if it breaks the
    protocol)."""
    if data.get("type") == "event":
        return _EVENT.validate_python(data)
    if data.get("type") == "state":
        return StateFrame.model_validate(data)
    if data.get("type") == "plan":
        return PlanFrame.model_validate(data)
    return EndFrame.model_validate(data)

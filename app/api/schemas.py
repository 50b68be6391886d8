"""The API's pydantic schemas (the shapes of docs/mission-format.md), separate from the storage
models.

Units: metres for positions and lengths, radians for angles (headings ψ, joint angles),
model seconds for simulated time, wall milliseconds for planning latency.
"""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, RootModel, model_validator
from pydantic import Strict as StrictNumber  # no bool or string coerced into a number

from app.missions.parts import Angle
from app.missions.spec import Coord, GoalSpec, Joint, ObstacleSpec, Pose
from app.missions.status import MissionStatus
from app.service.frames import PoseOut
from primitives.shapes import SHAPES, is_shape
from sim.robot import DEFAULT_GEOMETRY


class TransitionOut(BaseModel):
    """One status change, in order (the mission's audit trail of statuses)."""

    status: MissionStatus = Field(description="the status entered")
    at: datetime = Field(description="when (UTC, wall clock)")
    reason: str = Field(description="why: a replan trigger, a failure, a request; may be empty")


class GoalOut(BaseModel):
    """A goal of the mission and whether the tracked point reached it."""

    x: float = Field(description="goal x, metres (world frame)")
    y: float = Field(description="goal y, metres (world frame)")
    tolerance: float = Field(description="radius around the goal that counts, metres")
    reached: bool = Field(default=False, description="the tracked point came within tolerance")
    error: float | None = Field(
        default=None, description="distance to the goal when reached, metres"
    )
    reached_at: float | None = Field(default=None, description="when reached, model seconds")
    removed: bool = Field(default=False, description="removed by a live update; not pursued")
    source: Literal["request", "live"] = Field(
        default="request",
        description="how it came: in the mission as posted, or by `POST /missions/{id}/goals`",
    )
    added_at: float = Field(
        default=0.0, description="when it came, model seconds (0 for the request's goals)"
    )
    removed_at: float | None = Field(
        default=None, description="when a live update removed it, model seconds"
    )


class KnownObstacleOut(BaseModel):
    """An obstacle the robot's world model knows from the start or from a live update (hidden
    obstacles are not listed: the robot has only sensed them, see `/world`)."""

    id: str = Field(
        description="`request-N` (index N of the posted `obstacles`) or `live-N` (the N-th "
        "obstacle added live)"
    )
    source: Literal["request", "live"] = Field(
        description="how it came: in the mission as posted, or by `POST /missions/{id}/obstacles`"
    )
    added_at: float = Field(description="when it came, model seconds (0 for the request's)")
    obstacle: dict[str, Any] = Field(
        description="the obstacle as in a mission's `obstacles` (`type` circle, rectangle or "
        "polygon; metres, radians); a rectangle added live is listed as the polygon of its "
        "corners, as the world model holds it"
    )


MISSION_EXAMPLE: dict[str, Any] = {
    "id": "0b4c2a8e-6a1f-4f43-9a57-3f3c2f0d9e51",
    "name": "fig9a-single-goal",
    "status": "succeeded",
    "reason": "all goals reached",
    "created_at": "2026-01-01T12:00:00Z",
    "transitions": [
        {"status": "queued", "at": "2026-01-01T12:00:00Z", "reason": ""},
        {"status": "planning", "at": "2026-01-01T12:00:00.1Z", "reason": ""},
        {"status": "executing", "at": "2026-01-01T12:00:00.3Z", "reason": ""},
        {"status": "succeeded", "at": "2026-01-01T12:00:02Z", "reason": "all goals reached"},
    ],
    "goals": [
        {
            "x": -3.0,
            "y": -3.0,
            "tolerance": 0.1,
            "reached": True,
            "error": 0.03,
            "reached_at": 91,
            "removed": False,
            "source": "request",
            "added_at": 0.0,
            "removed_at": None,
        }
    ],
    "obstacles": [],
    "pose": {"x": -2.98, "y": -2.99, "psi": -2.3, "joints": [0.0, 0.0, 0.0]},
    "model_time": 91.25,
    "collisions": 0,
    "replans": 0,
    "request": {"name": "fig9a-single-goal", "goals": [{"x": -3, "y": -3, "tolerance": 0.1}]},
}


class MissionOut(BaseModel):
    """A mission: its request, status and history, and its latest state while it runs."""

    model_config = ConfigDict(json_schema_extra={"examples": [MISSION_EXAMPLE]})
    id: str = Field(description="the mission's id (a UUID); its URL is /missions/{id}")
    name: str = Field(description="the name given in the request")
    status: MissionStatus = Field(description="the current status")
    reason: str = Field(description="why it is in this status (the terminal reason at the end)")
    created_at: datetime = Field(description="when it was posted (UTC)")
    transitions: list[TransitionOut] = Field(description="every status change, oldest first")
    goals: list[GoalOut] = Field(
        description="the goals in the order posted (their index names them), live ones "
        "included, with progress"
    )
    obstacles: list[KnownObstacleOut] = Field(
        default=[],
        description="the known obstacles: those posted known, then those added live, each with "
        "when and how it came",
    )
    pose: PoseOut = Field(description="the latest pose (the start pose before it runs)")
    model_time: float = Field(description="simulated time so far, model seconds")
    collisions: int = Field(description="contacts the bumpers reported so far")
    replans: int = Field(description="replans so far (the first plan not counted)")
    request: dict[str, Any] = Field(
        description="the mission as posted (see MissionSpec), defaults filled in"
    )


class MissionPage(BaseModel):
    """One page of missions, newest first."""

    items: list[MissionOut] = Field(description="the missions on this page")
    total: int = Field(description="how many missions match, on all pages")
    limit: int = Field(description="page size asked for")
    offset: int = Field(description="how many matching missions were skipped")


class ReplanOut(BaseModel):
    """One replan: what triggered it, how long planning took, the plan before and after."""

    trigger: str = Field(
        description="the typed trigger's kind: obstacle_sensed, path_blocked, contact, "
        "shape_changed, no_progress, timeout, goals_changed, obstacle_added, resumed"
    )
    at: float = Field(description="when, model seconds")
    latency_ms: float = Field(description="planning time, wall milliseconds")
    old: list[str] = Field(description="the remaining steps of the plan replaced (PDDL actions)")
    new: list[str] = Field(description="the new plan's steps (PDDL actions)")
    detail: dict[str, Any] = Field(default={}, description="the trigger's fields")
    status: str = Field(default="solved", description="solved, or why no plan was found")


class PlanOut(BaseModel):
    """The mission's current plan (latest version) and every replan so far."""

    mission: str = Field(description="the mission's id")
    version: int = Field(description="plan version, 1 for the first plan; 0 before planning")
    domain: str = Field(description="the planning domain: navigation or reactive")
    actions: list[dict[str, Any]] = Field(
        description="the plan's actions with their grounding (primitive, heading, duration)"
    )
    replans: list[ReplanOut] = Field(description="every replan, oldest first")


class PddlOut(BaseModel):
    """One plan version as PDDL: what another planner can be given."""

    version: int = Field(description="plan version (1, 2, ...)")
    domain: str = Field(description="the PDDL domain text")
    problem: str = Field(
        description="the PDDL problem text; empty when it is not inline (`problem_inline`)"
    )
    plan: list[str] = Field(description="the plan found, one PDDL action per item")
    problem_inline: bool = Field(
        default=True,
        description="whether `problem` holds the text: problems past `SCREWSNAKE_PDDL_INLINE` "
        "bytes in all are not inline, only at `problem_url`",
    )
    problem_url: str = Field(
        default="", description="where the problem alone is (text/plain, gzip when accepted)"
    )
    problem_bytes: int | None = Field(
        default=None, description="the problem text's size in bytes (null: not rendered yet)"
    )


class TrajectoryOut(BaseModel):
    """Where the robot went, thinned to at most 2000 evenly spaced rows (the last included)."""

    mission: str = Field(description="the mission's id")
    points: list[list[float]] = Field(
        description="rows [t, x, y, ψ, φ1, φ2, φ3]: model seconds, metres, radians"
    )


class SimulateIn(BaseModel):
    """One open-loop rollout of one parameter set (the paper's U1/U2: joints, U3: phases)."""

    model_config = ConfigDict(
        extra="forbid",
        json_schema_extra={
            "examples": [{"theta": [-0.1, 0.53, -0.12, 0.5], "phases": [0.6, -0.5, -0.3]}]
        },
    )
    theta: Annotated[
        list[Annotated[float, StrictNumber(), Field(allow_inf_nan=False, ge=-1, le=1)]],
        Field(
            min_length=4,
            max_length=4,
            description="the four screw speeds θ1..θ4, normalised to [-1, 1] (rad/s at 1)",
        ),
    ]
    joints: Annotated[list[Joint], Field(min_length=3, max_length=3)] | None = Field(
        default=None, description="held joint angles φ1..φ3, radians (U2); none: straight"
    )
    phases: (
        Annotated[
            list[Angle],
            Field(min_length=3, max_length=3),
        ]
        | None
    ) = Field(default=None, description="gait phases ϕ1..ϕ3, radians: φi = 0.2 sin(0.6 t + ϕi)")
    duration: Annotated[
        float,
        StrictNumber(),
        Field(allow_inf_nan=False, gt=0, le=3600, description="model seconds"),
    ] = 100.0
    dt: Annotated[
        float,
        StrictNumber(),
        Field(allow_inf_nan=False, ge=0.01, le=10, description="Euler step, model seconds"),
    ] = 1.0
    start: Pose = Field(default=Pose(), description="start pose (metres, radians)")
    joint_mode: Literal["paper", "complete"] = Field(
        default="paper",
        description="paper: the paper's kinematics; complete: adds the joint-rate terms",
    )
    max_points: Annotated[
        int,
        StrictNumber(),
        Field(
            ge=2,
            le=100_000,
            description="at most this many rows come back: every n-th step, the last included",
        ),
    ] = 2000

    @model_validator(mode="after")
    def _one(self) -> SimulateIn:
        if self.joints is not None and self.phases is not None:
            raise ValueError("joints: give joints or phases, not both")
        if self.duration / self.dt > 100_000:
            raise ValueError("dt: more than 100000 steps")
        if self.dt > self.duration:
            raise ValueError("dt: larger than the duration")
        return self


class SimulateOut(BaseModel):
    """The rollout: thinned rows and the exact end pose."""

    points: list[list[float]] = Field(
        description="rows [t, x, y, ψ, φ1, φ2, φ3]: model seconds, metres, radians"
    )
    stride: int = Field(default=1, description="every stride-th Euler step is a row (thinning)")
    steps: int = Field(default=0, description="Euler steps simulated (rows before thinning)")
    end: dict[str, float] = Field(description="end pose: x, y (metres), psi (radians)")


class LearnIn(BaseModel):
    """Learn one primitive (parameters that carry the robot to ``goal`` in one rollout), or,
    given ``joints``, the full lattice set of that fixed shape, which joins the library."""

    model_config = ConfigDict(
        extra="forbid",
        json_schema_extra={
            "examples": [
                {"goal": [-2, -2], "learner": "pi2-cma", "seed": 1},
                {"joints": [0.9, -0.3, 0.6]},
            ]
        },
    )
    goal: (
        tuple[
            Annotated[float, StrictNumber(), Field(allow_inf_nan=False, ge=-7, le=7)],
            Annotated[float, StrictNumber(), Field(allow_inf_nan=False, ge=-7, le=7)],
        ]
        | None
    ) = Field(
        default=None,
        description="target displacement of the tracked point (start frame), metres",
    )
    joints: tuple[Joint, Joint, Joint] | None = Field(
        default=None,
        description=(
            "a fixed body shape's joint angles (radians, within the joint limits): learn its "
            "lattice primitives with PI²-CMA from a seed derived from the shape (goal, shape, "
            "learner, seed, threshold and max_updates do not apply); they join the library as "
            "a new version unless that shape is there already"
        ),
    )
    shape: str = Field(
        default="straight",
        description=f"body shape held: free, one of {', '.join(SHAPES)} or a learned shape's name",
    )
    learner: Literal["pi2", "pi2-cma", "cmaes"] = Field(
        default="pi2", description="pi2 (the paper's), pi2-cma or cmaes"
    )
    seed: Annotated[
        int, StrictNumber(), Field(ge=0, le=2**31, description="random seed (deterministic)")
    ] = 0
    threshold: Annotated[
        float,
        StrictNumber(),
        Field(allow_inf_nan=False, ge=0.005, le=1, description="stop under this end error, m"),
    ] = 0.05
    max_updates: Annotated[
        int, StrictNumber(), Field(ge=1, le=500, description="learner updates at most")
    ] = 100

    @model_validator(mode="after")
    def _shape(self) -> LearnIn:
        if self.shape != "free" and not is_shape(self.shape):
            raise ValueError(f"shape: unknown {self.shape!r}; known: free, {', '.join(SHAPES)}")
        if (self.goal is None) == (self.joints is None):
            raise ValueError("goal: give a goal (one primitive) or joints (a lattice set)")
        limit = DEFAULT_GEOMETRY.max_joint_angle
        if self.joints is not None and max(abs(v) for v in self.joints) > limit:
            raise ValueError(
                f"joints: {list(self.joints)} is outside the joint limits (±{limit:.2f} rad)"
            )
        return self


class JobOut(BaseModel):
    """A learning job and its progress."""

    id: str = Field(description="the job's id; its URL is /jobs/{id}")
    kind: str = Field(description="the job kind: learn")
    status: str = Field(description="queued, running, succeeded, failed or cancelled")
    reason: str = Field(description="why it is in this status")
    created_at: datetime = Field(description="when it was posted (UTC)")
    request: dict[str, Any] = Field(description="the request as posted (LearnIn)")
    progress: dict[str, Any] = Field(description="updates done and the best cost so far")
    result: dict[str, Any] | None = Field(description="the learned primitive when it succeeded")


class PrimitiveSummary(BaseModel):
    """One library primitive, briefly (GET /primitives/{id} has everything)."""

    id: str = Field(description="the primitive's id")
    label: str | None = Field(description="the paper's Table 2 label (P1s ...), if any")
    shape: str = Field(description="the body shape it holds")
    space: str = Field(description="parameter space: U1, U2 (fixed shape) or U3 (gait)")
    family: str = Field(description="paper (Fig. 6 goals) or lattice (planner moves)")
    duration: float = Field(description="how long one execution lasts, model seconds")
    goal: list[float] = Field(description="target displacement (start frame), metres")
    direction: float = Field(description="direction of the goal, degrees from +x")
    cost: float = Field(description="the learner's final cost (end error, metres)")


class PrimitiveList(BaseModel):
    """The primitives of the running library."""

    library: str = Field(description="the library version (content hash, 12 hex digits)")
    count: int = Field(description="how many items")
    items: list[PrimitiveSummary] = Field(description="the primitives")


class GoalAdd(BaseModel):
    """A goal appended to a running mission (its index is the next after those posted)."""

    model_config = ConfigDict(extra="forbid", json_schema_extra={"examples": [{"x": 1, "y": 2}]})
    x: Coord = Field(description="goal x, metres (world frame)")
    y: Coord = Field(description="goal y, metres (world frame)")
    tolerance: Annotated[
        float,
        StrictNumber(),
        Field(allow_inf_nan=False, gt=0, le=5.0, description="radius that counts, m"),
    ] = 0.1

    def spec(self) -> GoalSpec:
        return GoalSpec(x=self.x, y=self.y, tolerance=self.tolerance)


OBSTACLE_EXAMPLES: dict[str, Any] = {
    "circle": {
        "summary": "A circle, as in a mission's `obstacles`",
        "value": {"type": "circle", "x": 1.0, "y": 0.5, "radius": 0.3},
    },
    "rectangle": {
        "summary": "A rotated rectangle (width along its own x axis, angle in radians)",
        "value": {"type": "rectangle", "x": 2, "y": -1, "width": 1.5, "height": 0.2, "angle": 0.5},
    },
    "polygon": {
        "summary": "A polygon given by its vertices",
        "value": {"type": "polygon", "points": [[0, 3], [1, 3], [0.5, 4]]},
    },
}


class ObstacleBody(RootModel[ObstacleSpec]):
    """The body of `POST /missions/{id}/obstacles`: the obstacle itself, as in a mission's
    `obstacles` (as `POST /goals` takes the goal itself). The earlier form, the obstacle under
    `obstacle`, is still taken."""

    @model_validator(mode="before")
    @classmethod
    def _unwrap(cls, value: Any) -> Any:
        if isinstance(value, dict) and set(value) == {"obstacle"}:
            return value["obstacle"]
        return value


class UpdateOut(BaseModel):
    """A live update accepted: the running mission replans with it."""

    mission: str = Field(description="the mission's id")
    update: str = Field(description="add_goal, remove_goal, add_obstacle, pause or resume")
    goal: int | None = Field(
        default=None,
        description="the goal's index: as posted, then in the order added (add and remove)",
    )
    obstacle: int | None = Field(
        default=None,
        description="the obstacle's index among the mission's obstacles: as posted, then in "
        "the order added (add_obstacle)",
    )
    status: MissionStatus = Field(description="the mission's status when accepted")


__all__ = ["Coord", "PoseOut"]

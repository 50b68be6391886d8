"""The API's pydantic schemas (DESIGN §10), separate from the storage models."""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from app.missions.spec import Coord, Joint, Pose
from primitives.shapes import SHAPES

Finite = Annotated[float, Field(allow_inf_nan=False)]


class TransitionOut(BaseModel):
    status: str
    at: datetime
    reason: str


class GoalOut(BaseModel):
    x: float
    y: float
    tolerance: float
    reached: bool = False
    error: float | None = None
    reached_at: float | None = None


class PoseOut(BaseModel):
    x: float
    y: float
    psi: float
    joints: list[float]


class MissionOut(BaseModel):
    id: str
    name: str
    status: str
    reason: str
    created_at: datetime
    transitions: list[TransitionOut]
    goals: list[GoalOut]
    pose: PoseOut
    model_time: float
    collisions: int
    replans: int
    request: dict[str, Any]


class MissionPage(BaseModel):
    items: list[MissionOut]
    total: int
    limit: int
    offset: int


class ReplanOut(BaseModel):
    trigger: str
    at: float
    latency_ms: float
    old: list[str]
    new: list[str]
    detail: dict[str, Any] = {}
    status: str = "solved"


class PlanOut(BaseModel):
    mission: str
    version: int
    domain: str
    actions: list[dict[str, Any]]
    replans: list[ReplanOut]


class PddlOut(BaseModel):
    version: int
    domain: str
    problem: str
    plan: list[str]


class TrajectoryOut(BaseModel):
    mission: str
    points: list[list[float]]


class SimulateIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    theta: Annotated[
        list[Annotated[float, Field(allow_inf_nan=False, ge=-1, le=1)]],
        Field(min_length=4, max_length=4),
    ]
    joints: Annotated[list[Joint], Field(min_length=3, max_length=3)] | None = None
    phases: (
        Annotated[
            list[Annotated[float, Field(allow_inf_nan=False, ge=-100, le=100)]],
            Field(min_length=3, max_length=3),
        ]
        | None
    ) = None
    duration: Annotated[float, Field(allow_inf_nan=False, gt=0, le=3600)] = 100.0
    dt: Annotated[float, Field(allow_inf_nan=False, ge=0.01, le=10)] = 1.0
    start: Pose = Pose()
    joint_mode: Literal["paper", "complete"] = "paper"

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
    points: list[list[float]]
    end: dict[str, float]


class LearnIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    goal: tuple[
        Annotated[float, Field(allow_inf_nan=False, ge=-7, le=7)],
        Annotated[float, Field(allow_inf_nan=False, ge=-7, le=7)],
    ]
    shape: str = "straight"
    learner: Literal["pi2", "pi2-cma", "cmaes"] = "pi2"
    seed: Annotated[int, Field(ge=0, le=2**31)] = 0
    threshold: Annotated[float, Field(allow_inf_nan=False, ge=0.005, le=1)] = 0.05
    max_updates: Annotated[int, Field(ge=1, le=500)] = 100

    @model_validator(mode="after")
    def _shape(self) -> LearnIn:
        if self.shape != "free" and self.shape not in SHAPES:
            raise ValueError(f"shape: unknown {self.shape!r}; known: free, {', '.join(SHAPES)}")
        return self


class JobOut(BaseModel):
    id: str
    kind: str
    status: str
    reason: str
    created_at: datetime
    request: dict[str, Any]
    progress: dict[str, Any]
    result: dict[str, Any] | None


__all__ = ["Coord"]

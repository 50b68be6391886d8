"""Read endpoints for the viewer: a mission's world model and everything needed to replay it."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter
from pydantic import BaseModel, Field

from app.api.deps import MissionId, Svc
from app.api.errors import responses
from app.api.missions import found, plan_of
from app.api.schemas import ReplanOut

router = APIRouter(tags=["missions"])


class WorldOut(BaseModel):
    """The robot's world model as last stored: sensed occupancy and contact cells (centres)."""

    mission: str = Field(description="the mission's id")
    model_time: float = Field(description="when it was stored, model seconds")
    resolution: float | None = Field(description="cell size of the grid, metres")
    sensed: list[list[float]] = Field(description="centres [x, y] of cells sensed occupied, m")
    contacts: list[list[float]] = Field(description="centres [x, y] of cells a bumper felt, m")


class PlanVersionOut(BaseModel):
    """One plan version and when it was made."""

    version: int = Field(description="plan version, 1 for the first")
    at: float | None = Field(description="when it was made, model seconds (None if unknown)")
    plan: list[str] = Field(description="the plan's steps (PDDL actions)")
    actions: list[dict[str, Any]] = Field(description="the steps with their grounding")


class ReplayOut(BaseModel):
    """A mission's trajectory rows ``[t, x, y, psi, phi1, phi2, phi3]``, its plans, replans and
    events (model times), for a replay with a time slider."""

    mission: str = Field(description="the mission's id")
    status: str = Field(description="the mission's status")
    trajectory: list[list[float]] = Field(
        description="rows [t, x, y, ψ, φ1, φ2, φ3]: model seconds, metres, radians"
    )
    plans: list[PlanVersionOut] = Field(description="every plan version, oldest first")
    replans: list[ReplanOut] = Field(description="every replan, oldest first")
    events: list[dict[str, Any]] = Field(description="the mission's events (model seconds t)")


@router.get("/missions/{mission_id}/world", response_model=WorldOut, responses=responses(404))
def get_world(mission_id: MissionId, svc: Svc) -> WorldOut:
    """The sensed world model of a mission (stored about once a second while it runs)."""
    state = found(svc, mission_id).state or {}
    return WorldOut(
        mission=mission_id,
        model_time=state.get("model_time", 0.0),
        resolution=state.get("resolution"),
        sensed=state.get("sensed", []),
        contacts=state.get("contacts", []),
    )


@router.get("/missions/{mission_id}/replay", response_model=ReplayOut, responses=responses(404))
def get_replay(mission_id: MissionId, svc: Svc) -> ReplayOut:
    """Trajectory, every plan version with its model time, replans and events of a mission."""
    row = found(svc, mission_id)
    state = row.state or {}
    times: list[float] = state.get("plan_times", [])
    plans = [
        PlanVersionOut(
            version=p.version,
            at=times[p.version - 1] if 0 < p.version <= len(times) else None,
            plan=p.plan,
            actions=p.actions,
        )
        for p in svc.store.plans(mission_id, texts=False)
    ]
    return ReplayOut(
        mission=mission_id,
        status=row.status,
        trajectory=svc.store.trajectory(mission_id) or [],
        plans=plans,
        replans=plan_of(svc, mission_id).replans,
        events=state.get("events", []),
    )

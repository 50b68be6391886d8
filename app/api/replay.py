"""Read endpoints for the viewer: a mission's world model and everything needed to replay it."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter
from pydantic import BaseModel

from app.api.deps import Svc
from app.api.missions import found, plan_of
from app.api.schemas import ReplanOut

router = APIRouter(tags=["missions"])


class WorldOut(BaseModel):
    """The robot's world model as last stored: sensed occupancy and contact cells (centres)."""

    mission: str
    model_time: float
    resolution: float | None
    sensed: list[list[float]]
    contacts: list[list[float]]


class PlanVersionOut(BaseModel):
    version: int
    at: float | None  # model time the plan was made (None if unknown)
    plan: list[str]
    actions: list[dict[str, Any]]


class ReplayOut(BaseModel):
    """A mission's trajectory rows ``[t, x, y, psi, phi1, phi2, phi3]``, its plans, replans and
    events (model times), for a replay with a time slider."""

    mission: str
    status: str
    trajectory: list[list[float]]
    plans: list[PlanVersionOut]
    replans: list[ReplanOut]
    events: list[dict[str, Any]]


@router.get("/missions/{mission_id}/world", response_model=WorldOut)
def get_world(mission_id: str, svc: Svc) -> WorldOut:
    """The sensed world model of a mission (stored about once a second while it runs)."""
    state = found(svc, mission_id).state or {}
    return WorldOut(
        mission=mission_id,
        model_time=state.get("model_time", 0.0),
        resolution=state.get("resolution"),
        sensed=state.get("sensed", []),
        contacts=state.get("contacts", []),
    )


@router.get("/missions/{mission_id}/replay", response_model=ReplayOut)
def get_replay(mission_id: str, svc: Svc) -> ReplayOut:
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
        for p in svc.store.plans(mission_id)
    ]
    return ReplayOut(
        mission=mission_id,
        status=row.status,
        trajectory=svc.store.trajectory(mission_id) or [],
        plans=plans,
        replans=plan_of(svc, mission_id).replans,
        events=state.get("events", []),
    )

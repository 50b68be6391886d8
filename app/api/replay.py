"""Read endpoints for the viewer: a mission's world model and everything needed to replay it."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Query, Response
from pydantic import BaseModel, Field

from app.api.deps import MissionId, Svc
from app.api.errors import responses
from app.api.known import current_goals, known_obstacle_data
from app.api.missions import found, json_answer, plan_of
from app.api.schemas import GoalOut, KnownObstacleOut, ReplanOut
from app.service.world_history import world_at

router = APIRouter(tags=["missions"])


class WorldOut(BaseModel):
    """The robot's world model: what it knows (the goals, the known obstacles, posted or added
    live) and what it sensed (occupancy and contact cells, by their centres)."""

    mission: str = Field(description="the mission's id")
    model_time: float = Field(description="the model time it shows, model seconds")
    resolution: float | None = Field(description="cell size of the grid, metres")
    sensed: list[list[float]] = Field(description="centres [x, y] of cells sensed occupied, m")
    contacts: list[list[float]] = Field(description="centres [x, y] of cells a bumper felt, m")
    goals: list[GoalOut] = Field(
        default=[], description="the goals by index, live ones included (as the mission's)"
    )
    obstacles: list[KnownObstacleOut] = Field(
        default=[], description="the known obstacles, live ones included, with when they came"
    )


class WorldChange(BaseModel):
    """Cells that came and went in one layer of the world model."""

    added: list[list[float]] = Field(default=[], description="centres [x, y] that came, m")
    removed: list[list[float]] = Field(default=[], description="centres [x, y] that went, m")


class WorldVersion(BaseModel):
    """How the world model changed at one model time (recorded at most once a model second)."""

    t: float = Field(description="model seconds")
    sensed: WorldChange | None = Field(default=None, description="sensed occupancy cells")
    contacts: WorldChange | None = Field(default=None, description="contact cells")


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
    world: list[WorldVersion] = Field(
        default=[],
        description="the world model's changes, oldest first: applying those up to a time "
        "gives the sensed and contact cells at that time (empty while it runs)",
    )
    goals: list[GoalOut] = Field(default=[], description="the goals, each with `added_at`")
    obstacles: list[KnownObstacleOut] = Field(
        default=[], description="the known obstacles, each with `added_at`"
    )


@router.get("/missions/{mission_id}/world", response_model=WorldOut, responses=responses(404))
def get_world(
    mission_id: MissionId,
    svc: Svc,
    at: Annotated[
        float | None,
        Query(
            ge=0,
            le=1e6,
            allow_inf_nan=False,
            description="a finished mission's world model as it was at this model time, "
            "seconds (none: as it is now, or as it ended)",
        ),
    ] = None,
) -> Response:
    """The world model of a mission: while it runs, as stored about once a second; with `at`,
    as it was then (a finished mission's goals and obstacles are those that had come by
    then)."""
    row = found(svc, mission_id)
    state = row.state or {}
    sensed, contacts = state.get("sensed", []), state.get("contacts", [])
    goals, obstacles = current_goals(row), known_obstacle_data(row)
    model_time = state.get("model_time", 0.0)
    if at is not None:
        changes = svc.store.world_history(mission_id)
        if changes is not None:  # else only the last stored model exists
            cells = world_at(changes, at)
            sensed, contacts, model_time = cells["sensed"], cells["contacts"], min(at, model_time)
        goals = [g for g in goals if g.added_at <= at]
        obstacles = [o for o in obstacles if o["added_at"] <= at]
    world = WorldOut(
        mission=mission_id,
        model_time=model_time,
        resolution=state.get("resolution"),
        sensed=sensed,
        contacts=contacts,
        goals=goals,
    )
    # The known obstacles as the data the store holds, and the answer written in this thread
    # (``app.api.missions.resource_data``: 10,000 of them as models held the GIL for tens of ms).
    return json_answer(world.model_dump(mode="json") | {"obstacles": obstacles})


@router.get("/missions/{mission_id}/replay", response_model=ReplayOut, responses=responses(404))
def get_replay(mission_id: MissionId, svc: Svc) -> Response:
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
    replay = ReplayOut(
        mission=mission_id,
        status=row.status,
        trajectory=svc.store.trajectory(mission_id) or [],
        plans=plans,
        replans=plan_of(svc, mission_id).replans,
        events=state.get("events", []),
        world=[WorldVersion.model_validate(c) for c in svc.store.world_history(mission_id) or []],
        goals=current_goals(row),
    )
    return json_answer(replay.model_dump(mode="json") | {"obstacles": known_obstacle_data(row)})

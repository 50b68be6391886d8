"""Live updates of a running mission (goals, known obstacles, pause, resume) and its event log.

Each update reaches the mission's worker as a typed message, becomes a typed trigger there
(GoalsChanged, ObstacleAdded, Resumed) that replans, and shows in the transitions, on the
websocket (an ``update`` event, then the replan) and in the event log.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from typing import Annotated, Any

from fastapi import APIRouter, Depends, Path
from fastapi.responses import StreamingResponse
from pydantic import ValidationError

from app.api.deps import MissionId, Services, Svc, writer
from app.api.errors import ApiError, responses
from app.api.missions import found
from app.api.schemas import GoalAdd, ObstacleAdd, UpdateOut
from app.api.validated import ValidatedRoute
from app.missions.spec import MissionSpec
from app.missions.status import TERMINAL, MissionStatus
from app.service.messages import AddGoal, AddObstacle, Pause, RemoveGoal, Resume, Update
from app.store.models import MissionRow

router = APIRouter(tags=["missions"], route_class=ValidatedRoute)  # bodies off the loop
WRITE: dict[str, Any] = {
    "status_code": 202,
    "response_model": UpdateOut,
    "dependencies": [Depends(writer)],
}
JSONL = "application/jsonl"


def running(svc: Services, mission_id: str) -> MissionRow:
    """The mission, if it can take an update now: 404 unknown, 409 ended or not started."""
    row = found(svc, mission_id)
    if row.status in TERMINAL:
        raise ApiError(409, f"mission {mission_id} already ended ({row.status})")
    if row.status in (MissionStatus.QUEUED, MissionStatus.CANCELLING):
        raise ApiError(409, f"mission {mission_id} is {row.status}: only running missions update")
    return row


def send(svc: Services, row: MissionRow, update: Update, goal: int | None = None) -> UpdateOut:
    if not svc.supervisor.update(row.id, update):
        raise ApiError(409, f"mission {row.id} is not running")
    return UpdateOut(
        mission=row.id, update=update.kind, goal=goal, status=MissionStatus(row.status)
    )


def goals_now(row: MissionRow) -> list[dict[str, Any]]:
    """The goals as the mission last reported them (as posted, with live additions)."""
    stored: list[dict[str, Any]] = (row.state or {}).get("goals") or []
    return stored or list(row.request.get("goals", []))


@router.post("/missions/{mission_id}/goals", **WRITE, responses=responses(401, 404, 409, 422))
def add_goal(mission_id: MissionId, goal: GoalAdd, svc: Svc) -> UpdateOut:
    """Append a goal to a running mission; it replans (trigger `goals_changed`). The new
    goal's index follows the goals as posted."""
    row = running(svc, mission_id)
    if row.request.get("chain"):
        raise ApiError(409, f"mission {mission_id} runs a chain of primitives: it has no goals")
    goals = goals_now(row)
    posted = [{"x": g["x"], "y": g["y"], "tolerance": g["tolerance"]} for g in goals]
    try:  # the mission's own checks: inside the bounds, outside known obstacles, reachable
        MissionSpec.model_validate({**row.request, "goals": [*posted, goal.model_dump()]})
    except ValidationError as exc:
        message = str(exc.errors()[0]["msg"]).removeprefix("Value error, ")
        raise ApiError(422, message.replace(f"goals.{len(posted)}", "goal"), "body") from exc
    return send(svc, row, AddGoal(goal.x, goal.y, goal.tolerance), goal=len(posted))


@router.delete(
    "/missions/{mission_id}/goals/{index}", **WRITE, responses=responses(401, 404, 409, 422)
)
def remove_goal(
    mission_id: MissionId,
    index: Annotated[int, Path(ge=0, le=10_000, description="the goal's index, as posted")],
    svc: Svc,
) -> UpdateOut:
    """Stop pursuing a goal; it replans. A reached goal cannot be removed (409)."""
    row = running(svc, mission_id)
    goals = goals_now(row)
    if index >= len(goals):
        raise ApiError(404, f"mission {mission_id} has no goal {index} (0..{len(goals) - 1})")
    if goals[index].get("reached"):
        raise ApiError(409, f"goal {index} was already reached")
    if goals[index].get("removed"):
        raise ApiError(409, f"goal {index} was already removed")
    return send(svc, row, RemoveGoal(index), goal=index)


@router.post("/missions/{mission_id}/obstacles", **WRITE, responses=responses(401, 404, 409, 422))
def add_obstacle(mission_id: MissionId, body: ObstacleAdd, svc: Svc) -> UpdateOut:
    """Add a known obstacle to the mission's world model; it replans (`obstacle_added`)."""
    row = running(svc, mission_id)
    obstacle = body.obstacle.model_dump() | {"known": True}
    return send(svc, row, AddObstacle(obstacle))


@router.post("/missions/{mission_id}/pause", **WRITE, responses=responses(401, 404, 409))
def pause(mission_id: MissionId, svc: Svc) -> UpdateOut:
    """Hold the robot still: model time stops until `resume` (or `cancel`)."""
    row = running(svc, mission_id)
    if row.status == MissionStatus.PAUSED:
        raise ApiError(409, f"mission {mission_id} is already paused")
    return send(svc, row, Pause())


@router.post("/missions/{mission_id}/resume", **WRITE, responses=responses(401, 404, 409))
def resume(mission_id: MissionId, svc: Svc) -> UpdateOut:
    """Go on from where it paused; it replans (`resumed`)."""
    row = running(svc, mission_id)
    if row.status != MissionStatus.PAUSED:
        raise ApiError(409, f"mission {mission_id} is not paused ({row.status})")
    return send(svc, row, Resume())


@router.get(
    "/missions/{mission_id}/events",
    response_class=StreamingResponse,
    responses={
        200: {
            "description": "JSON lines: every transition (wall clock `at`), then the mission's "
            "events (model seconds `t`: replans, updates, goals reached, collisions, ...)",
            "content": {JSONL: {"schema": {"type": "string"}}},
        },
        **responses(404),
    },
)
def get_events(mission_id: MissionId, svc: Svc) -> StreamingResponse:
    """The mission's audit trail as JSON lines (one JSON object per line)."""
    row = found(svc, mission_id)
    transitions = svc.store.transitions(mission_id)
    events: list[dict[str, Any]] = (row.state or {}).get("events") or []

    def lines() -> Iterator[str]:
        for t in transitions:
            line = {"source": "transition", "at": t.at.isoformat(), "status": t.status}
            yield json.dumps(line | {"reason": t.reason}) + "\n"
        for event in events:
            yield json.dumps({"source": "mission", **event}) + "\n"

    headers = {"Content-Disposition": f'attachment; filename="mission-{mission_id}.jsonl"'}
    return StreamingResponse(lines(), media_type=JSONL, headers=headers)

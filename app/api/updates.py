"""Live updates of a running mission (goals, known obstacles, pause, resume) and its event log.

Each update reaches the mission's worker as a typed message, becomes a typed trigger there
(GoalsChanged, ObstacleAdded, Resumed) that replans, and shows in the transitions, on the
websocket (an ``update`` event, then the replan) and in the event log. The rules (the running
mission's one account of its goals and obstacles, the caps, the checks) are in
``app.service.live``; a refusal there is answered as a problem (``app.api.limits``).
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from typing import Annotated, Any

from fastapi import APIRouter, Body, Depends, Path
from fastapi.responses import StreamingResponse

from app.api.deps import MissionId, Svc, writer
from app.api.errors import responses
from app.api.missions import found
from app.api.schemas import OBSTACLE_EXAMPLES, GoalAdd, ObstacleBody, UpdateOut
from app.api.validated import ValidatedRoute

router = APIRouter(tags=["missions"], route_class=ValidatedRoute)
WRITE: dict[str, Any] = {
    "status_code": 202,
    "response_model": UpdateOut,
    "dependencies": [Depends(writer)],
}
JSONL = "application/jsonl"


@router.post("/missions/{mission_id}/goals", **WRITE, responses=responses(401, 404, 409, 422, 503))
async def add_goal(mission_id: MissionId, goal: GoalAdd, svc: Svc) -> UpdateOut:
    """Append a goal to a running mission; it replans (trigger `goals_changed`). The answer's
    `goal` is its index: the next after the goals posted and added before (the same the
    mission's `goals` and `DELETE .../goals/{index}` use). Checked like a posted goal against
    the mission's current world (its obstacles, those added live too): 422 naming the field;
    at most `SCREWSNAKE_MAX_GOALS` goals (422)."""
    index, status = await svc.live.add_goal(mission_id, goal.model_dump())
    return UpdateOut(mission=mission_id, update="add_goal", goal=index, status=status)


@router.delete(
    "/missions/{mission_id}/goals/{index}", **WRITE, responses=responses(401, 404, 409, 422)
)
async def remove_goal(
    mission_id: MissionId,
    index: Annotated[int, Path(ge=0, le=10_000, description="the goal's index, as posted")],
    svc: Svc,
) -> UpdateOut:
    """Stop pursuing a goal; it replans. A reached goal cannot be removed (409), nor the last
    goal not reached (409: cancel the mission instead)."""
    status = await svc.live.remove_goal(mission_id, index)
    return UpdateOut(mission=mission_id, update="remove_goal", goal=index, status=status)


@router.post(
    "/missions/{mission_id}/obstacles", **WRITE, responses=responses(401, 404, 409, 422, 503)
)
async def add_obstacle(
    mission_id: MissionId,
    body: Annotated[ObstacleBody, Body(openapi_examples=OBSTACLE_EXAMPLES)],
    svc: Svc,
) -> UpdateOut:
    """Add a known obstacle to the mission's world model; it replans (`obstacle_added`). Not on
    the robot's body as it last reported, nor over a goal still to reach (422 naming
    `obstacle`); at most `SCREWSNAKE_MAX_LIVE_OBSTACLES` per mission (422). The answer's
    `obstacle` is its index among the mission's obstacles (posted, then added)."""
    obstacle = body.root.model_dump() | {"known": True}
    index, status = await svc.live.add_obstacle(mission_id, obstacle)
    return UpdateOut(mission=mission_id, update="add_obstacle", obstacle=index, status=status)


@router.post("/missions/{mission_id}/pause", **WRITE, responses=responses(401, 404, 409))
async def pause(mission_id: MissionId, svc: Svc) -> UpdateOut:
    """Hold the robot still: model time stops until `resume` (or `cancel`). Pausing a paused
    mission is a 409."""
    status = await svc.live.pause(mission_id)
    return UpdateOut(mission=mission_id, update="pause", status=status)


@router.post("/missions/{mission_id}/resume", **WRITE, responses=responses(401, 404, 409))
async def resume(mission_id: MissionId, svc: Svc) -> UpdateOut:
    """Go on from where it paused; it replans (`resumed`). Resuming a mission that is not
    paused is a 409."""
    status = await svc.live.resume(mission_id)
    return UpdateOut(mission=mission_id, update="resume", status=status)


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

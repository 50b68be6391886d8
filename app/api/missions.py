"""Missions: create (idempotent), list, get, cancel, and their plan, trajectory, PDDL, tree."""

from __future__ import annotations

from typing import Annotated, Any

import orjson
from fastapi import APIRouter, Body, Depends, Header, Query, Response
from starlette.concurrency import run_in_threadpool

from app import timing
from app.api.deps import MissionId, Services, Svc, writer
from app.api.errors import ApiError, responses
from app.api.examples import mission_examples
from app.api.known import current_goals, known_obstacle_data
from app.api.limits import check_mission
from app.api.schemas import (
    MissionOut,
    MissionPage,
    PlanOut,
    PoseOut,
    ReplanOut,
    TrajectoryOut,
    TransitionOut,
)
from app.api.validated import ValidatedRoute
from app.missions.maps import InlineMapSpec
from app.missions.spec import MissionSpec
from app.missions.status import TERMINAL, MissionStatus
from app.service.maps import store_inline
from app.service.supervisor import QueueFull
from app.store.models import MissionRow

router = APIRouter(tags=["missions"], route_class=ValidatedRoute)  # bodies off the loop


def _brief(
    svc: Services, row: MissionRow, transitions: list[TransitionOut] | None = None
) -> MissionOut:
    """The mission as the API shows it but for its bulk (the request and the known obstacles
    are left empty); ``transitions`` when known (else read). A running mission's goals are its
    live account's (``app.service.live``: added and removed ones included at once), not the
    state its worker last saved."""
    state = row.state or {}
    live = svc.supervisor.live_goals(row.id) if row.status not in TERMINAL else None
    start = row.request.get("start", {})
    pose = state.get("pose") or {
        "x": start.get("x", 0.0),
        "y": start.get("y", 0.0),
        "psi": start.get("psi", 0.0),
        "joints": [0.0, 0.0, 0.0],
    }
    return MissionOut(
        id=row.id,
        name=row.name,
        status=MissionStatus(row.status),
        reason=row.reason,
        created_at=row.created_at,
        transitions=transitions
        if transitions is not None
        else [
            TransitionOut(status=MissionStatus(t.status), at=t.at, reason=t.reason)
            for t in svc.store.transitions(row.id)
        ],
        goals=current_goals(row, live),
        obstacles=[],
        pose=PoseOut.model_validate(pose),
        model_time=state.get("model_time", 0.0),
        collisions=state.get("collisions", 0),
        replans=state.get("replans", 0),
        request={},
    )


def resource_data(
    svc: Services, row: MissionRow, transitions: list[TransitionOut] | None = None
) -> dict[str, Any]:
    """The mission as the API shows it (``MissionOut``), as the JSON data its model dumps to.
    Its bulk, the request and the known obstacles (10,000 of each in a large mission), is the
    data the store holds, as it is: as models it cost ~40 ms of one thread's hold on the GIL,
    which every other request then waited for."""
    data = _brief(svc, row, transitions).model_dump(mode="json")
    data["obstacles"] = known_obstacle_data(row)
    data["request"] = row.request
    return data


def resource_json(
    svc: Services, row: MissionRow, transitions: list[TransitionOut] | None = None
) -> bytes:
    """``resource_data`` as the answer's JSON, for a route to build in a thread (FastAPI would
    check and write a returned model on the event loop)."""
    return orjson.dumps(resource_data(svc, row, transitions))


def json_answer(data: Any, status_code: int = 200) -> Response:
    """An answer of JSON data written by orjson (in the route's thread)."""
    return Response(orjson.dumps(data), status_code=status_code, media_type="application/json")


async def store_maps(svc: Services, spec: MissionSpec, request: dict[str, Any]) -> None:
    """A mission's inline maps are stored once by content hash (``POST /maps``'s store) and
    named by id in the stored request: a mission row never holds a map's image."""
    inline = [(k, m) for k, m in enumerate(spec.maps) if isinstance(m, InlineMapSpec)]
    if not inline:
        return
    rasters = spec.world_maps()
    ids = await run_in_threadpool(
        store_inline, svc.store, [(entry, rasters[k][0]) for k, entry in inline]
    )
    for (k, entry), map_id in zip(inline, ids, strict=True):
        request["maps"][k] = {"id": map_id, "known": entry.known}


def found(svc: Services, mission_id: str) -> MissionRow:
    row = svc.store.get_mission(mission_id)
    if row is None:
        raise ApiError(404, f"mission {mission_id} not found")
    return row


def check_library(svc: Services, spec: MissionSpec) -> None:
    """Chain steps and reactive operators must name primitives the running library has (422
    naming the field)."""
    unknown = spec.unknown_primitive(svc.library)
    if unknown is not None:
        i, name = unknown
        raise ApiError(422, f"chain.{i}: primitive {name!r} is not in the library", f"chain.{i}")
    for op, name in spec.planner.operators.items():
        entry = svc.library.get(name) if name in svc.library else None
        if entry is None or entry.periodic:
            why = "is not in the library" if entry is None else "is periodic (no fixed shape)"
            field = f"planner.operators.{op}"
            raise ApiError(422, f"{field}: primitive {name!r} {why}", field)


@router.post(
    "/missions",
    status_code=201,
    response_model=MissionOut,
    dependencies=[Depends(writer)],
    responses={
        201: {"description": "Created and queued; `Location` is its URL"},
        200: {
            "model": MissionOut,
            "description": "A replay: this `Idempotency-Key` created this same mission before",
        },
        **responses(401, 409, 413, 422, 503),
    },
)
async def create_mission(
    spec: Annotated[MissionSpec, Body(openapi_examples=mission_examples())],
    svc: Svc,
    idempotency_key: Annotated[
        str | None,
        Header(
            max_length=200,
            description="a retry with the same key returns the mission it created (200)",
        ),
    ] = None,
) -> Response:
    """Validate and store the mission, then queue it; a retried Idempotency-Key returns it again."""
    timing.lap("accept")  # the body read and validated, the dependencies solved
    check_library(svc, spec)
    check_mission(spec, svc.settings, svc.library)
    # A full queue refuses a new mission before any work on it (the intake refuses it too,
    # and stores nothing); a retried Idempotency-Key is answered by the intake first, full or not.
    if idempotency_key is None and svc.supervisor.full():
        raise QueueFull()
    # In a thread, as the answer below: for 10,000 obstacles each is tens of milliseconds of
    # Python that would stall the event loop in one piece (a thread yields it the GIL).
    request = await run_in_threadpool(spec.model_dump, mode="json", by_alias=True)
    await store_maps(svc, spec, request)
    timing.lap("validate")
    # Stored and queued with the other missions posted meanwhile (app.service.intake): one
    # thread hop and one transaction for a burst, not one each.
    row, created = await svc.intake.create(spec.name, request, idempotency_key)
    timing.lap("store")  # its batch: waiting for it, the thread hop, the transaction
    if created:  # its one transition is known: nothing to read back
        queued = [TransitionOut(status=MissionStatus.QUEUED, at=row.created_at, reason="")]
        body = await run_in_threadpool(resource_json, svc, row, queued)
    elif row.request == request:  # a retry: the mission as it is now
        body = await run_in_threadpool(resource_json, svc, row)
    else:
        raise ApiError(
            409, f"Idempotency-Key was used for a different mission ({row.id})", "Idempotency-Key"
        )
    timing.lap("resource")
    return Response(
        body,
        status_code=201 if created else 200,
        media_type="application/json",
        headers={"Location": f"/missions/{row.id}"},
    )


@router.get("/missions", response_model=MissionPage, responses=responses(422))
def list_missions(
    svc: Svc,
    status: Annotated[
        MissionStatus | None, Query(description="only missions in this status")
    ] = None,
    limit: Annotated[int, Query(ge=1, le=200, description="page size")] = 50,
    offset: Annotated[int, Query(ge=0, le=10**9, description="missions to skip")] = 0,
) -> Response:
    rows, total = svc.store.list_missions(status, limit, offset)
    items = [resource_data(svc, r) for r in rows]
    return json_answer({"items": items, "total": total, "limit": limit, "offset": offset})


@router.get("/missions/{mission_id}", response_model=MissionOut, responses=responses(404))
def get_mission(mission_id: MissionId, svc: Svc) -> Response:
    return json_answer(resource_data(svc, found(svc, mission_id)))


@router.post(
    "/missions/{mission_id}/cancel",
    response_model=MissionOut,
    status_code=202,
    dependencies=[Depends(writer)],
    responses=responses(401, 404, 409),
)
def cancel_mission(mission_id: MissionId, svc: Svc) -> Response:
    row = found(svc, mission_id)
    if row.status in TERMINAL:
        raise ApiError(409, f"mission {mission_id} already ended ({row.status})")
    svc.supervisor.cancel(mission_id)
    return json_answer(resource_data(svc, found(svc, mission_id)), status_code=202)


def plan_of(svc: Services, mission_id: str) -> PlanOut:
    found(svc, mission_id)
    plans = svc.store.plans(mission_id, texts=False, last=True)
    replans = [
        ReplanOut(
            trigger=r.trigger,
            at=r.at,
            latency_ms=r.latency_ms,
            old=r.old,
            new=r.new,
            detail=r.detail,
            status=r.status,
        )
        for r in svc.store.replans(mission_id)
    ]
    if not plans:
        return PlanOut(mission=mission_id, version=0, domain="", actions=[], replans=replans)
    last = plans[-1]
    return PlanOut(
        mission=mission_id,
        version=last.version,
        domain=last.domain,
        actions=last.actions,
        replans=replans,
    )


@router.get("/missions/{mission_id}/plan", response_model=PlanOut, responses=responses(404))
def get_plan(mission_id: MissionId, svc: Svc) -> PlanOut:
    return plan_of(svc, mission_id)


@router.get("/plan", response_model=PlanOut, responses=responses(404, 422))
def get_plan_query(
    svc: Svc,
    mission: Annotated[
        str | None, Query(max_length=64, description="a mission's id; none: the latest")
    ] = None,
) -> PlanOut:
    """The plan of ``?mission=ID``, or of the latest mission."""
    if mission is None:
        latest = svc.store.latest_mission()
        if latest is None:
            raise ApiError(404, "there are no missions yet")
        mission = latest.id
    return plan_of(svc, mission)


@router.get(
    "/missions/{mission_id}/trajectory", response_model=TrajectoryOut, responses=responses(404)
)
def get_trajectory(mission_id: MissionId, svc: Svc) -> TrajectoryOut:
    """Where the robot went; while the mission runs, its path so far as the state frames
    told it (a row every 0.25 model s at most)."""
    found(svc, mission_id)
    points = svc.store.trajectory(mission_id)
    if points is None:
        points = list(svc.hub.trails.get(mission_id, []))
    return TrajectoryOut(mission=mission_id, points=points)


@router.get("/missions/{mission_id}/tree", responses=responses(404))
def get_tree(mission_id: MissionId, svc: Svc) -> dict[str, Any]:
    """The behaviour tree as last seen: names, types, statuses, feedback, children (empty
    before it runs; a finished mission's root shows how it ended)."""
    row = found(svc, mission_id)
    stored: dict[str, Any] = (row.state or {}).get("tree") or {}
    if row.status in TERMINAL and stored:
        return stored
    tree: dict[str, Any] = svc.hub.last_tree.get(mission_id) or stored
    return tree

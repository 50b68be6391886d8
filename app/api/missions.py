"""Missions: create (idempotent), list, get, cancel, and their plan, trajectory, PDDL, tree."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Depends, Header, HTTPException, Query, Response

from app.api.deps import Services, Svc, writer
from app.api.limits import check_mission
from app.api.schemas import (
    GoalOut,
    MissionOut,
    MissionPage,
    PddlOut,
    PlanOut,
    PoseOut,
    ReplanOut,
    TrajectoryOut,
    TransitionOut,
)
from app.missions.spec import MissionSpec
from app.service.supervisor import QueueFull
from app.store.models import MissionRow

router = APIRouter(tags=["missions"])
STATUSES = (
    "queued",
    "planning",
    "executing",
    "replanning",
    "cancelling",
    "succeeded",
    "failed",
    "cancelled",
)


def resource(svc: Services, row: MissionRow) -> MissionOut:
    state = row.state or {}
    spec_goals = row.request.get("goals", [])
    goals = state.get("goals") or [
        {"x": g["x"], "y": g["y"], "tolerance": g.get("tolerance", 0.1)} for g in spec_goals
    ]
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
        status=row.status,
        reason=row.reason,
        created_at=row.created_at,
        transitions=[
            TransitionOut(status=t.status, at=t.at, reason=t.reason)
            for t in svc.store.transitions(row.id)
        ],
        goals=[GoalOut.model_validate(g) for g in goals],
        pose=PoseOut.model_validate(pose),
        model_time=state.get("model_time", 0.0),
        collisions=state.get("collisions", 0),
        replans=state.get("replans", 0),
        request=row.request,
    )


def found(svc: Services, mission_id: str) -> MissionRow:
    row = svc.store.get_mission(mission_id)
    if row is None:
        raise HTTPException(404, f"mission {mission_id} not found")
    return row


def check_library(svc: Services, spec: MissionSpec) -> None:
    """Chain steps and reactive operators must name primitives the running library has (422
    naming the field)."""
    for i, step in enumerate(spec.chain):
        names = (
            [step.primitive]
            if step.primitive
            else list(step.interpolate.from_ if step.interpolate else [])
        )
        for name in names:
            if name not in svc.library:
                raise HTTPException(422, f"chain.{i}: primitive {name!r} is not in the library")
    for op, name in spec.planner.operators.items():
        entry = svc.library.get(name) if name in svc.library else None
        if entry is None or entry.periodic:
            why = "is not in the library" if entry is None else "is periodic (no fixed shape)"
            raise HTTPException(422, f"planner.operators.{op}: primitive {name!r} {why}")


@router.post(
    "/missions", status_code=201, response_model=MissionOut, dependencies=[Depends(writer)]
)
def create_mission(
    spec: MissionSpec,
    response: Response,
    svc: Svc,
    idempotency_key: Annotated[str | None, Header(max_length=200)] = None,
) -> MissionOut:
    """Validate and store the mission, then queue it; a retried Idempotency-Key returns it again."""
    check_library(svc, spec)
    check_mission(spec, svc.settings, svc.library)
    if svc.supervisor.full():  # before the row: never a stored mission that cannot run
        raise QueueFull()
    row, created = svc.store.create_mission(
        spec.name, spec.model_dump(mode="json", by_alias=True), idempotency_key
    )
    if created:
        svc.metrics.created.inc()
        svc.supervisor.submit(row.id, force=True)
    else:
        response.status_code = (
            200 if row.request == spec.model_dump(mode="json", by_alias=True) else 409
        )
        if response.status_code == 409:
            raise HTTPException(409, "Idempotency-Key was used for a different mission")
    response.headers["Location"] = f"/missions/{row.id}"
    return resource(svc, row)


@router.get("/missions", response_model=MissionPage)
def list_missions(
    svc: Svc,
    status: Annotated[str | None, Query(pattern="^(" + "|".join(STATUSES) + ")$")] = None,
    limit: Annotated[int, Query(ge=1, le=200)] = 50,
    offset: Annotated[int, Query(ge=0, le=10**9)] = 0,
) -> MissionPage:
    rows, total = svc.store.list_missions(status, limit, offset)
    return MissionPage(
        items=[resource(svc, r) for r in rows], total=total, limit=limit, offset=offset
    )


@router.get("/missions/{mission_id}", response_model=MissionOut)
def get_mission(mission_id: str, svc: Svc) -> MissionOut:
    return resource(svc, found(svc, mission_id))


@router.post(
    "/missions/{mission_id}/cancel",
    response_model=MissionOut,
    status_code=202,
    dependencies=[Depends(writer)],
)
def cancel_mission(mission_id: str, svc: Svc) -> MissionOut:
    row = found(svc, mission_id)
    if row.status in ("succeeded", "failed", "cancelled"):
        raise HTTPException(409, f"mission {mission_id} already ended ({row.status})")
    svc.supervisor.cancel(mission_id)
    return resource(svc, found(svc, mission_id))


def plan_of(svc: Services, mission_id: str) -> PlanOut:
    found(svc, mission_id)
    plans = svc.store.plans(mission_id)
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


@router.get("/missions/{mission_id}/plan", response_model=PlanOut)
def get_plan(mission_id: str, svc: Svc) -> PlanOut:
    return plan_of(svc, mission_id)


@router.get("/plan", response_model=PlanOut)
def get_plan_query(
    svc: Svc, mission: Annotated[str | None, Query(max_length=64)] = None
) -> PlanOut:
    """The plan of ``?mission=ID``, or of the latest mission."""
    if mission is None:
        latest = svc.store.latest_mission()
        if latest is None:
            raise HTTPException(404, "there are no missions yet")
        mission = latest.id
    return plan_of(svc, mission)


@router.get("/missions/{mission_id}/trajectory", response_model=TrajectoryOut)
def get_trajectory(mission_id: str, svc: Svc) -> TrajectoryOut:
    found(svc, mission_id)
    return TrajectoryOut(mission=mission_id, points=svc.store.trajectory(mission_id) or [])


@router.get("/missions/{mission_id}/pddl", response_model=list[PddlOut])
def get_pddl(mission_id: str, svc: Svc) -> list[PddlOut]:
    found(svc, mission_id)
    return [
        PddlOut(version=p.version, domain=p.domain_pddl, problem=p.problem_pddl, plan=p.plan)
        for p in svc.store.plans(mission_id)
    ]


@router.get("/missions/{mission_id}/tree")
def get_tree(mission_id: str, svc: Svc) -> dict[str, Any]:
    """The latest behaviour-tree snapshot the mission broadcast (empty before it runs); an
    ended mission's comes from the store."""
    row = found(svc, mission_id)
    live = svc.hub.last_tree.get(mission_id)
    tree: dict[str, Any] = live if live is not None else (row.state or {}).get("tree", {})
    return tree

"""Liveness, readiness and Prometheus metrics.

Alive (``/livez``) is not ready: ``/readyz`` answers 200 only when the database answers and
enough mission workers have finished their warm-up (``SCREWSNAKE_READY_WORKERS``), so that a
mission posted now starts at once instead of waiting seconds for a worker to load its kernels.
"""

from __future__ import annotations

from typing import Any, Literal

from fastapi import APIRouter, Request
from fastapi.responses import Response
from prometheus_client import CONTENT_TYPE_LATEST, generate_latest
from pydantic import BaseModel, Field

from app.api.deps import Services, Svc
from app.api.errors import PROBLEM, problem
from app.api.faults import DbHealth
from app.store.db import DatabaseLost

router = APIRouter(tags=["health"])
NOT_READY_RETRY_AFTER = 1  # seconds: a warm-up takes a few


class WorkerWarmth(BaseModel):
    """How many of the pool's mission workers can start a mission at once."""

    warm: int = Field(
        description="workers whose warm-up (kernels, motion tables) has ended; a replaced "
        "worker is cold until its own warm-up ends"
    )
    size: int = Field(description="workers in the pool (`SCREWSNAKE_MAX_RUNNING`)")
    needed: int = Field(
        description="warm workers needed to be ready (`SCREWSNAKE_READY_WORKERS`, at most "
        "`size`; 0: readiness does not wait for them)"
    )


class Readiness(BaseModel):
    """The service is ready: missions posted now are stored and start without a warm-up."""

    status: Literal["ok"] = Field(description="always `ok` (not ready is a 503 problem)")
    database: Literal["ok"] = Field(description="the database answered just now")
    library: str = Field(description="the primitive library's version (its content hash)")
    primitives: int = Field(description="primitives in the loaded library")
    workers: WorkerWarmth = Field(description="the mission workers' warm-up")


# The 503: a problem, with the workers' warmth when they are what is not ready.
NOT_READY = {
    "allOf": [
        {"$ref": "#/components/schemas/Problem"},
        {
            "type": "object",
            "properties": {
                "workers": {
                    "$ref": "#/components/schemas/WorkerWarmth",
                    "description": "the mission workers' warm-up (when they are not ready)",
                }
            },
        },
    ]
}


def warmth(svc: Services) -> WorkerWarmth:
    """The pool's warmth now, and how much of it readiness needs."""
    warm, size = svc.supervisor.warmth()
    return WorkerWarmth(warm=warm, size=size, needed=min(svc.settings.ready_workers, size))


@router.get("/livez")
def livez() -> dict[str, str]:
    return {"status": "ok"}


@router.get(
    "/readyz",
    response_model=Readiness,
    responses={
        503: {
            "description": "Not ready: the database failed recently, takes no write, or its "
            "file was deleted or replaced under the server; or too few mission workers have "
            "warmed up yet (the detail says which; `workers` counts them)",
            "content": {PROBLEM: {"schema": NOT_READY}},
        }
    },
)
def readyz(svc: Svc, request: Request) -> Any:
    """Ready when the database takes a write, is the file the server opened (not deleted or
    replaced under it), and has not failed recently (see app.api.faults), and at
    least ``SCREWSNAKE_READY_WORKERS`` mission workers are warm; says which library is loaded
    and how warm the pool is."""
    health: DbHealth = request.app.state.db_health
    try:
        svc.store.probe()  # the file as opened, and a write that commits
    except DatabaseLost as exc:  # for as long as it lasts: a restart opens the file anew
        health.failed(exc)
        return problem(503, f"database unavailable: {exc.reason}; restart the server")
    except Exception as exc:  # not ready: say why (the kind only: no URL, no path)
        health.failed(exc)
    if not health.healthy:
        return problem(503, f"database unavailable: failed recently ({health.kind})")
    workers = warmth(svc)
    if workers.warm < workers.needed:
        detail = f"workers warming up ({workers.warm}/{workers.size} warm)"
        if workers.needed > 1:
            detail += f"; {workers.needed} needed"
        response = problem(503, detail, workers=workers.model_dump())
        response.headers["Retry-After"] = str(NOT_READY_RETRY_AFTER)
        return response
    return Readiness(
        status="ok",
        database="ok",
        library=svc.library_version,
        primitives=len(svc.library),
        workers=workers,
    )


@router.get(
    "/metrics",
    response_class=Response,
    responses={
        200: {
            "description": "Prometheus text format",
            "content": {CONTENT_TYPE_LATEST: {"schema": {"type": "string"}}},
        }
    },
)
def metrics(svc: Svc) -> Response:
    m = svc.metrics
    m.ws_clients.set(svc.hub.clients)
    warm, size = svc.supervisor.warmth()
    m.workers_warm.set(warm)
    m.workers.set(size)
    return Response(generate_latest(m.registry), media_type=CONTENT_TYPE_LATEST)

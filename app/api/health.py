"""Liveness, readiness and Prometheus metrics."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Request
from fastapi.responses import Response
from prometheus_client import CONTENT_TYPE_LATEST, generate_latest
from sqlalchemy import text

from app.api.deps import Svc
from app.api.errors import PROBLEM, problem
from app.api.faults import DbHealth

router = APIRouter(tags=["health"])


@router.get("/livez")
def livez() -> dict[str, str]:
    return {"status": "ok"}


@router.get(
    "/readyz",
    response_model=None,
    responses={
        503: {
            "description": "Not ready: the database failed recently (the detail says how)",
            "content": {PROBLEM: {"schema": {"$ref": "#/components/schemas/Problem"}}},
        }
    },
)
def readyz(svc: Svc, request: Request) -> Any:
    """Ready when the database answers and has not failed recently (see app.api.faults);
    says which library is loaded."""
    health: DbHealth = request.app.state.db_health
    try:
        with svc.store.engine.connect() as conn:
            conn.execute(text("SELECT 1"))
    except Exception as exc:  # not ready: say why (the kind only: no URL, no path)
        health.failed(exc)
    if not health.healthy:
        return problem(503, f"database unavailable: failed recently ({health.kind})")
    return {
        "status": "ok",
        "database": "ok",
        "library": svc.library_version,
        "primitives": len(svc.library),
    }


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
    return Response(generate_latest(m.registry), media_type=CONTENT_TYPE_LATEST)

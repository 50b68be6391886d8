"""Liveness, readiness and Prometheus metrics."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter
from fastapi.responses import Response
from prometheus_client import CONTENT_TYPE_LATEST, generate_latest
from sqlalchemy import text

from app.api.deps import Svc
from app.api.errors import PROBLEM, problem

router = APIRouter(tags=["health"])


@router.get("/livez")
def livez() -> dict[str, str]:
    return {"status": "ok"}


@router.get(
    "/readyz",
    response_model=None,
    responses={
        503: {
            "description": "Not ready: the database cannot be reached (the detail says why)",
            "content": {PROBLEM: {"schema": {"$ref": "#/components/schemas/Problem"}}},
        }
    },
)
def readyz(svc: Svc) -> Any:
    """Ready when the database answers; says which library is loaded."""
    try:
        with svc.store.engine.connect() as conn:
            conn.execute(text("SELECT 1"))
    except Exception as exc:  # not ready: say why
        return problem(503, f"database unavailable: {exc}")
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

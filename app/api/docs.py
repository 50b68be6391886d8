"""What the OpenAPI description says beyond the routes: units, errors, the websocket protocol
(its AsyncAPI document at ``/asyncapi.json``), and the tags."""

from __future__ import annotations

from functools import cache
from pathlib import Path
from typing import Any

import fastapi_offline
from fastapi import APIRouter, Request
from fastapi.openapi.docs import get_redoc_html
from fastapi.responses import HTMLResponse, Response

from app.api.frames import asyncapi

router = APIRouter(tags=["websocket"])

DESCRIPTION = """
Plans and runs missions for a snake robot with four screw-drive units, in simulation.

**Units.** Positions and lengths in metres, angles (headings ψ, joint angles φ) in radians,
simulated time in *model seconds*, planning latency in wall milliseconds. Coordinates are in
the world frame unless a field says *start frame*.

**Errors** are `application/problem+json` (RFC 9457): `title` is the generic HTTP phrase,
`detail` says what went wrong, and `field` (with `errors`, one per field) names the request
field at fault when one is. Each operation lists the codes it can answer.

**Writes** (`POST`) need `Authorization: Bearer <key>` when the server has an API key.

**Live updates.** A running mission accepts new goals (`POST /missions/{id}/goals`), goal
removals (`DELETE /missions/{id}/goals/{index}`, the index as posted), known obstacles
(`POST /missions/{id}/obstacles`), `pause` and `resume`; each replans and shows in the
transitions, the websocket and the event log (`GET /missions/{id}/events`, JSON lines).

**Websocket** `WS /missions/{id}/ws`: a `snapshot` frame first, then `state` frames (latest
wins, rate-limited), `event` frames (`kind`: status, replan, deform, collision, goal_reached,
obstacle_sensed, dropout, update) and `plan` frames in order, and always an `end` frame last.
Send `{"type": "ping"}` for a `pong`. Every frame's JSON Schema is in the AsyncAPI document at
[`/asyncapi.json`](/asyncapi.json).
"""

TAGS = [
    {"name": "missions", "description": "Post, follow, update and cancel missions."},
    {"name": "maps", "description": "Occupancy-grid maps in ROS map_server's format."},
    {"name": "primitives", "description": "The learned motor primitives the planner uses."},
    {"name": "simulate", "description": "Open-loop rollouts of one parameter set."},
    {"name": "jobs", "description": "Learning jobs: learn a primitive for a goal."},
    {"name": "health", "description": "Liveness, readiness, Prometheus metrics."},
    {"name": "websocket", "description": "The mission stream's protocol (AsyncAPI)."},
    {"name": "viewer", "description": "The example missions the browser viewer offers."},
]


@router.get("/asyncapi.json")
def get_asyncapi() -> dict[str, Any]:
    """The websocket protocol of ``/missions/{id}/ws`` as AsyncAPI 3.0, with a JSON Schema
    for every frame type."""
    return asyncapi()


# ReDoc's bundle draws its "API docs by Redocly" badge from its CDN (one failed request and a
# console error offline): served here with the badge's image inlined.
REDOC_JS = Path(fastapi_offline.__file__).parent / "static" / "redoc.standalone.js"
REDOC_LOGO = "https://cdn.redoc.ly/redoc/logo-mini.svg"
BLANK_SVG = "data:image/svg+xml,%3Csvg xmlns='http://www.w3.org/2000/svg' width='1' height='1'/%3E"


@cache
def redoc_bundle() -> bytes:
    return REDOC_JS.read_text(encoding="utf-8").replace(REDOC_LOGO, BLANK_SVG).encode("utf-8")


@router.get("/redoc", include_in_schema=False)
def redoc(request: Request) -> HTMLResponse:
    """ReDoc, with every asset from this app."""
    root = request.scope.get("root_path", "")
    return get_redoc_html(
        openapi_url=f"{root}/openapi.json",
        title="screwsnake - ReDoc",
        redoc_js_url=f"{root}/redoc.js",
        with_google_fonts=False,
        redoc_favicon_url=f"{root}/docs-assets/favicon.png",
    )


@router.get("/redoc.js", include_in_schema=False)
def redoc_js() -> Response:
    return Response(redoc_bundle(), media_type="text/javascript")

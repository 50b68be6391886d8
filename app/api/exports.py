"""What a mission exports: its plan versions' PDDL (``/pddl``, ``/pddl/{version}``) and its
world model as a map, as ROS's map_saver writes one (``/world.yaml``, ``/world.pgm``).

A worker stores what regenerates each version's problem, never its text (tens of megabytes for
a long tour): the text is rendered when asked, in the service's process pool, never on the
event loop. ``GET /missions/{id}/pddl`` holds the problems inline while they fit in
``SCREWSNAKE_PDDL_INLINE`` bytes in all and says where the others are; ``GET
/missions/{id}/pddl/{version}`` answers one problem as text, gzip-compressed when the client
accepts it, streamed, up to ``SCREWSNAKE_MAX_PDDL_ANSWER`` bytes (413 beyond).

The map is the world model as the worker last saved it (about once a second, and at the end):
occupied (known obstacles and maps, sensed occupancy), free (observed), unknown; the YAML names
its image ``world.pgm``, beside it (``app.service.world_map``).
"""

from __future__ import annotations

from collections.abc import AsyncIterator, Callable
from typing import Annotated, Any, Literal, TypeVar

from fastapi import APIRouter, Header, Path, Query
from fastapi.responses import PlainTextResponse, Response, StreamingResponse
from starlette.concurrency import run_in_threadpool

from app.api.deps import MissionId, Services, Svc
from app.api.errors import ApiError, responses
from app.api.schemas import PddlOut
from app.executor.plan_versions import SourceUnreadable
from app.service import world_map
from app.service.exports import TooLarge, answer, inline_texts
from app.store.repo import StoredPlan

router = APIRouter(tags=["missions"])
T = TypeVar("T")
CHUNK = 1 << 16  # bytes per streamed piece
Version = Annotated[int, Path(ge=1, le=1_000_000, description="the plan version (1, 2, ...)")]
Part = Literal["problem", "domain"]


def stored_plans(svc: Services, mission_id: str, version: int | None = None) -> list[StoredPlan]:
    if svc.store.get_mission(mission_id) is None:
        raise ApiError(404, f"mission {mission_id} not found")
    return svc.store.plans(mission_id, version=version)


def problem_url(mission_id: str, version: int) -> str:
    return f"/missions/{mission_id}/pddl/{version}"


def accepts_gzip(header: str | None) -> bool:
    """Whether an ``Accept-Encoding`` header accepts gzip (``gzip`` or ``*``, not ``q=0``)."""
    for item in (header or "").split(","):
        name, _, params = item.strip().partition(";")
        if name.strip().lower() in ("gzip", "*"):
            q = params.strip().removeprefix("q=").strip() if "q=" in params else "1"
            try:
                return float(q) > 0
            except ValueError:
                return False
    return False


async def rendered(svc: Services, fn: Callable[..., T], *args: Any) -> T:
    """``fn(*args)`` in the service's process pool; a source it cannot read is 409."""
    try:
        return await svc.validation.run(fn, *args)
    except SourceUnreadable as exc:
        raise ApiError(409, f"{exc}: stored by another version of the service") from exc


@router.get(
    "/missions/{mission_id}/pddl", response_model=list[PddlOut], responses=responses(404, 409, 503)
)
async def get_pddl(mission_id: MissionId, svc: Svc) -> list[PddlOut]:
    """Every plan version as PDDL: the domain, the plan and, while they fit in
    ``SCREWSNAKE_PDDL_INLINE`` bytes in all, the problem (else ``problem_url`` says where)."""
    plans = await run_in_threadpool(stored_plans, svc, mission_id)
    stored = [p.source if p.source is not None else p.problem_pddl for p in plans]
    texts = await rendered(svc, inline_texts, stored, svc.settings.pddl_inline)
    return [
        PddlOut(
            version=p.version,
            domain=p.domain_pddl,
            problem=text or "",
            plan=p.plan,
            problem_inline=text is not None,
            problem_url=problem_url(mission_id, p.version),
            problem_bytes=size,
        )
        for p, (text, size) in zip(plans, texts, strict=True)
    ]


async def pieces(data: bytes) -> AsyncIterator[bytes]:
    """The answer in pieces, on the loop (a plain iterator would take a thread per piece)."""
    view = memoryview(data)
    for start in range(0, len(view), CHUNK):
        yield bytes(view[start : start + CHUNK])


@router.get(
    "/missions/{mission_id}/pddl/{version}",
    response_class=StreamingResponse,
    responses={200: {"content": {"text/plain": {}}}, **responses(404, 409, 413, 503)},
)
async def get_pddl_version(
    mission_id: MissionId,
    version: Version,
    svc: Svc,
    part: Annotated[Part, Query(description="the problem, or the domain")] = "problem",
    accept_encoding: Annotated[
        str | None, Header(description="`gzip` for a gzip-compressed answer")
    ] = None,
) -> StreamingResponse:
    """One plan version's PDDL problem (or domain) as text: rendered off the event loop,
    gzip-compressed when the client accepts it, streamed; larger than
    ``SCREWSNAKE_MAX_PDDL_ANSWER`` bytes of text is 413."""
    plans = await run_in_threadpool(stored_plans, svc, mission_id, version)
    if not plans:
        raise ApiError(404, f"mission {mission_id} has no plan version {version}")
    plan = plans[0]
    if part == "domain":
        stored: str | bytes = plan.domain_pddl
    else:
        stored = plan.source if plan.source is not None else plan.problem_pddl
    limit = svc.settings.max_pddl_answer
    out = await rendered(svc, answer, stored, limit, accepts_gzip(accept_encoding))
    if isinstance(out, TooLarge):
        raise ApiError(
            413,
            f"plan version {version}'s PDDL {part} is {out.size} bytes, more than an answer may "
            f"hold (SCREWSNAKE_MAX_PDDL_ANSWER: {limit})",
        )
    headers = {"Content-Length": str(len(out.data)), "Vary": "Accept-Encoding"}
    if out.gzipped:
        headers["Content-Encoding"] = "gzip"
    name = f"{part}-v{version}.pddl"
    headers["Content-Disposition"] = f'inline; filename="{name}"'
    return StreamingResponse(
        pieces(out.data), media_type="text/plain; charset=utf-8", headers=headers
    )


def saved_map(svc: Services, mission_id: str) -> dict[str, Any]:
    """The world model's map as the mission last saved it (404: no mission, or none yet)."""
    row = svc.store.get_mission(mission_id)
    if row is None:
        raise ApiError(404, f"mission {mission_id} not found")
    packed: dict[str, Any] | None = (row.state or {}).get("map")
    if packed is None:
        raise ApiError(404, f"mission {mission_id} has no world model yet (it has not run)")
    return packed


@router.get(
    "/missions/{mission_id}/world.yaml",
    response_class=PlainTextResponse,
    responses={200: {"content": {"application/x-yaml": {}}}, **responses(404)},
)
async def get_world_yaml(mission_id: MissionId, svc: Svc) -> PlainTextResponse:
    """The world model as map_saver's YAML (map_server's parameters; its image is
    `world.pgm`, beside it): as last saved while the mission runs, as it ended after."""
    packed = await run_in_threadpool(saved_map, svc, mission_id)
    return PlainTextResponse(world_map.yaml(packed, "world.pgm"), media_type="application/x-yaml")


@router.get(
    "/missions/{mission_id}/world.pgm",
    response_class=Response,
    responses={200: {"content": {"image/x-portable-graymap": {}}}, **responses(404, 503)},
)
async def get_world_pgm(mission_id: MissionId, svc: Svc) -> Response:
    """The world model as map_saver's image: an 8-bit PGM, row 0 the top, occupied 0, free
    254, unknown 205. Written off the event loop."""
    packed = await run_in_threadpool(saved_map, svc, mission_id)
    image = await svc.validation.run(world_map.pgm, packed)
    return Response(image, media_type="image/x-portable-graymap")

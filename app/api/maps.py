"""Maps: post a ROS map_server map (its two files, or the JSON form), list and read them.

A map is decoded and checked in a validation process (never on the event loop), stored once by
its content hash, and named by that id in missions (``"maps": [{"id": ..., "known": true}]``).
``POST /maps`` has its own body limit (``SCREWSNAKE_MAX_MAP_BODY``).
"""

from __future__ import annotations

import base64
from datetime import datetime
from typing import Annotated, Any

from fastapi import APIRouter, Depends, Path, Query, Request, Response
from fastapi.exceptions import RequestValidationError
from pydantic import BaseModel, ConfigDict
from starlette.concurrency import run_in_threadpool

from app.api.deps import Svc, writer
from app.api.errors import ApiError, responses
from app.api.validated import is_json
from app.service.maps import (
    PreparedMap,
    image_base64,
    parse_form,
    parse_json,
    render_cells,
    stored_map,
)
from app.service.validation import Invalid
from app.store.models import MapRow

router = APIRouter(tags=["maps"])
MEDIA = {"pgm": "image/x-portable-graymap", "png": "image/png"}


class Described(BaseModel):
    # Attribute docstrings are the fields' descriptions in the OpenAPI schema.
    model_config = ConfigDict(use_attribute_docstrings=True)


class Extent(Described):
    """The world box a map covers."""

    xmin: float
    """west edge, metres"""
    xmax: float
    """east edge, metres"""
    ymin: float
    """south edge, metres"""
    ymax: float
    """north edge, metres"""


class Cells(Described):
    """How many of a map's cells are of each class."""

    occupied: int
    """cells with p > occupied_thresh"""
    free: int
    """cells with p < free_thresh"""
    unknown: int
    """the others (between the thresholds; transparent or out of range in scale and raw)"""


class MapSummary(Described):
    """A stored map: its parameters (map_server's) and what was read off its image."""

    id: str
    """the map's id, its content hash: name it in a mission's `maps`"""
    name: str
    """a name for people (the YAML's image file name when posted as files)"""
    created_at: datetime
    """when it was first stored"""
    resolution: float
    """metres per pixel"""
    origin: tuple[float, float, float]
    """[x, y, yaw] of the lower-left pixel's outer corner (metres, radians)"""
    negate: int
    """1: white is occupied and black free"""
    occupied_thresh: float
    """p above this is occupied"""
    free_thresh: float
    """p below this is free"""
    mode: str
    """trinary, scale or raw"""
    format: str
    """the image's format: pgm or png"""
    width: int
    """pixels"""
    height: int
    """pixels"""
    extent: Extent
    """the world box the map covers"""
    cells: Cells
    """how many cells are occupied, free, unknown"""


class MapOut(MapSummary):
    """A stored map with its image."""

    image: str | None = None
    """the image file as posted, base64 (unless `image=false`)"""


class MapPage(Described):
    """One page of maps, newest first (without their images)."""

    items: list[MapSummary]
    """the maps on this page"""
    total: int
    """how many maps there are, on all pages"""
    limit: int
    """page size asked for"""
    offset: int
    """how many maps were skipped"""


class MapCreated(Described):
    """The stored map's id and summary."""

    id: str
    """the map's id: name it in a mission's `maps` as {"id": ..., "known": true}"""
    map: MapSummary
    """the map as stored"""


MapId = Annotated[str, Path(description="the map's id (32 hex digits, from POST /maps)")]


def summary(row: MapRow) -> MapSummary:
    return MapSummary.model_validate(
        {"id": row.id, "name": row.name, "created_at": row.created_at, **row.meta}
    )


EXAMPLE_YAML = (
    "image: office.pgm\nresolution: 0.05\norigin: [-3.0, -2.0, 0.0]\nnegate: 0\n"
    "occupied_thresh: 0.65\nfree_thresh: 0.196\n"
)
EXAMPLE_JSON = {
    "image": base64.b64encode(b"P5\n3 2\n255\n" + bytes([0, 254, 254, 254, 254, 0])).decode(),
    "resolution": 0.5,
    "origin": [0.0, 0.0, 0.0],
    "name": "tiny",
}
_MAP_BODY: dict[str, Any] = {
    "requestBody": {
        "required": True,
        "description": (
            "The map as map_server's two files in a form (part `yaml`: the map's YAML; part "
            "`image`: the PGM or PNG it names), or as JSON (`image` base64, `resolution`, "
            "`origin`, `negate`, `occupied_thresh`, `free_thresh`, `mode`, `name`; a mission's map "
            "entry as it is, whose `known` is ignored)"
        ),
        "content": {
            "multipart/form-data": {
                "schema": {
                    "type": "object",
                    "required": ["yaml", "image"],
                    "properties": {
                        "yaml": {"type": "string", "format": "binary"},
                        "image": {"type": "string", "format": "binary"},
                    },
                },
                "examples": {
                    "office": {
                        "summary": "map_server's two files (curl -F yaml=@office.yaml -F image=@office.pgm)",
                        "value": {"yaml": EXAMPLE_YAML, "image": "(the PGM or PNG file)"},
                    }
                },
            },
            "application/json": {
                "schema": {"$ref": "#/components/schemas/InlineMapSpec"},
                "examples": {
                    "tiny": {
                        "summary": "a 3 x 2 PGM: occupied top-left and bottom-right",
                        "value": EXAMPLE_JSON,
                    }
                },
            },
        },
    }
}


@router.post(
    "/maps",
    status_code=201,
    response_model=MapCreated,
    dependencies=[Depends(writer)],
    openapi_extra=_MAP_BODY,
    responses={
        201: {"description": "Stored; `Location` is its URL"},
        200: {"model": MapCreated, "description": "The same map was stored before: its id"},
        **responses(401, 413, 422, 503),
    },
)
async def create_map(request: Request, response: Response, svc: Svc) -> MapCreated:
    """Decode, check and store a map (once, by content hash); its id names it in missions."""
    body = await request.body()
    content_type = request.headers.get("content-type", "")
    result: PreparedMap | Invalid
    if content_type.lower().startswith("multipart/form-data"):
        result = await svc.validation.run(parse_form, content_type, body)
    elif is_json(content_type) or not content_type:
        result = await svc.validation.run(parse_json, body)
    else:
        raise ApiError(
            422,
            f"body: send the map as multipart/form-data (parts yaml and image) or as JSON, "
            f"not {content_type.split(';')[0]}",
            "body",
        )
    if isinstance(result, Invalid):
        raise RequestValidationError(result.errors)
    row, created = await run_in_threadpool(
        svc.store.add_map, result.id, result.name, result.meta, result.image
    )
    response.status_code = 201 if created else 200
    response.headers["Location"] = f"/maps/{row.id}"
    return MapCreated(id=row.id, map=summary(row))


@router.get("/maps", response_model=MapPage, responses=responses(422))
def list_maps(
    svc: Svc,
    limit: Annotated[int, Query(ge=1, le=200, description="page size")] = 50,
    offset: Annotated[int, Query(ge=0, le=10**9, description="maps to skip")] = 0,
) -> MapPage:
    rows, total = svc.store.list_maps(limit, offset)
    return MapPage(items=[summary(r) for r in rows], total=total, limit=limit, offset=offset)


def found(svc: Svc, map_id: str) -> MapRow:
    row = svc.store.get_map(map_id) if len(map_id) == 32 else None
    if row is None:
        raise ApiError(404, f"map {map_id} not found")
    return row


@router.get("/maps/{map_id}", response_model=MapOut, responses=responses(404, 422))
def get_map(
    svc: Svc,
    map_id: MapId,
    image: Annotated[bool, Query(description="include the image (base64)")] = True,
) -> MapOut:
    """A stored map, its image included (base64): posted again, it is the same map."""
    row = found(svc, map_id)
    return MapOut(**summary(row).model_dump(), image=image_base64(row) if image else None)


@router.get(
    "/maps/{map_id}/cells.png",
    responses={200: {"content": {"image/png": {}}}, **responses(404, 422, 503)},
)
async def get_map_cells(svc: Svc, map_id: MapId) -> Response:
    """A stored map's cells as the viewer draws them (a PNG, row 0 the top): occupied dark,
    unknown light and half transparent, free transparent. Rendered off the event loop."""
    row = await run_in_threadpool(found, svc, map_id)
    png = await svc.validation.run(render_cells, bytes(row.image), stored_map(row).params)
    return Response(png, media_type="image/png", headers={"Cache-Control": "max-age=3600"})


@router.get(
    "/maps/{map_id}/image",
    responses={
        200: {"content": {"image/png": {}, "image/x-portable-graymap": {}}},
        **responses(404, 422),
    },
)
def get_map_image(svc: Svc, map_id: MapId) -> Response:
    """A stored map's image file as posted (PGM or PNG)."""
    row = found(svc, map_id)
    return Response(row.image, media_type=MEDIA.get(row.meta.get("format", ""), "image/png"))

"""The browser viewer (a static page, no build step) and the example missions it can post."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

from fastapi import APIRouter
from fastapi import Path as PathParam
from fastapi.responses import FileResponse

from app.api.errors import ApiError, responses
from app.paper_missions import examples_dir

router = APIRouter(tags=["viewer"])
STATIC = Path(__file__).resolve().parents[1] / "static"
ASSETS = {"viewer.js": "text/javascript", "map.js": "text/javascript", "viewer.css": "text/css"}


@router.get("/", include_in_schema=False)
def index() -> FileResponse:
    return FileResponse(STATIC / "index.html", media_type="text/html")


@router.get("/static/{name}", include_in_schema=False)
def asset(name: str) -> FileResponse:
    """The viewer's scripts and style sheet (a fixed list: nothing else is served)."""
    if name not in ASSETS:
        raise ApiError(404, f"no static file {name!r}")
    return FileResponse(STATIC / name, media_type=ASSETS[name])


@router.get("/examples")
def list_examples() -> dict[str, Any]:
    return {"items": sorted(p.stem for p in examples_dir().glob("*.json"))}


@router.get("/examples/{name}", responses=responses(404))
def get_example(name: Annotated[str, PathParam(description="an example's name")]) -> dict[str, Any]:
    names = {p.stem: p for p in examples_dir().glob("*.json")}
    if name not in names:
        raise ApiError(404, f"example {name!r} not found")
    data: dict[str, Any] = json.loads(names[name].read_text())
    return data

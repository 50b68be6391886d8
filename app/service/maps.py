"""Maps posted to the service (``POST /maps``): parsed, decoded and checked in a validation
process (an image of millions of pixels is seconds of work nobody else should wait for), then
stored once by content hash; and the stored maps a mission names, for its validation and its
worker.

A map arrives as the JSON form (``MapImageSpec``) or as ``map_server``'s two files in a
``multipart/form-data`` body: a part named ``yaml`` (the map's YAML; its ``image`` key names a
file, which is the part named ``image``) and the part named ``image``.
"""

from __future__ import annotations

import base64
import json
from dataclasses import dataclass
from typing import Any

from pydantic import ValidationError

from app.missions.maps import (
    InlineMapSpec,
    MapImageSpec,
    StoredMap,
    decode_map,
    inline_map,
    map_id,
    parse_map_yaml,
)
from app.service.validation import Invalid, _portable
from app.store.models import MapRow
from app.store.repo import Store
from sim.maps import MapError, MapParams, image_size
from sim.raster import OccupancyRaster

PARTS = ("yaml", "image")  # the form's parts: the map's two files
MAX_YAML = 64 * 1024  # bytes of a map's YAML (a dozen parameters)


@dataclass(frozen=True)
class PreparedMap:
    """A map checked and ready to store: its id, name, what ``GET /maps`` shows (``meta``)
    and its image file."""

    id: str
    name: str
    meta: dict[str, Any]
    image: bytes


def invalid(field: str, message: str) -> Invalid:
    """One 422 error naming ``field`` (as FastAPI's: ``loc`` starting with ``body``)."""
    return Invalid([{"type": "value_error", "loc": ("body", *field.split(".")), "msg": message}])


def describe(spec: MapImageSpec, raster: OccupancyRaster) -> dict[str, Any]:
    """A map's parameters and what was read off it: ``meta`` as stored and shown."""
    kind, width, height = image_size(spec.image_bytes())
    xmin, xmax, ymin, ymax = raster.extent()
    return {
        **spec.model_dump(mode="json", exclude={"image", "name", "known"}),
        "format": kind,
        "width": width,
        "height": height,
        "extent": {"xmin": xmin, "xmax": xmax, "ymin": ymin, "ymax": ymax},
        "cells": raster.counts(),
    }


def prepare(spec: MapImageSpec, raster: OccupancyRaster | None = None) -> PreparedMap:
    """A checked map (``raster`` when it was decoded already) ready to store."""
    if raster is None:
        raster = decode_map(spec, None, True, "map")
    return PreparedMap(map_id(spec), spec.name, describe(spec, raster), spec.image_bytes())


def _checked(spec: MapImageSpec) -> PreparedMap | Invalid:
    try:
        return prepare(spec)
    except ValueError as exc:  # "map.image: why"
        field, _, message = str(exc).removeprefix("map.").partition(": ")
        return invalid(field, message)


def parse_json(body: bytes) -> PreparedMap | Invalid:
    """In a validation process: a JSON map (``MapImageSpec``), decoded and checked."""
    try:
        data = json.loads(body)
    except (json.JSONDecodeError, UnicodeDecodeError, RecursionError):
        return invalid("body", "send a map as JSON (application/json) or as its two files")
    if isinstance(data, dict):
        data.pop("known", None)  # a mission's map entry posted as it is: known is the mission's
    try:
        spec = MapImageSpec.model_validate(data)
    except ValidationError as exc:
        return Invalid([_portable(dict(e)) for e in exc.errors(include_url=False)])
    try:
        spec.image_bytes()
    except MapError as exc:
        return invalid(exc.field, exc.message)
    return _checked(spec)


def parse_form(content_type: str, body: bytes) -> PreparedMap | Invalid:
    """In a validation process: ``map_server``'s two files as a multipart form (parts
    ``yaml`` and ``image``), decoded and checked."""
    from python_multipart.multipart import MultipartParser, parse_options_header

    _, options = parse_options_header(content_type)
    boundary = options.get(b"boundary")
    if not boundary:
        return invalid("body", "a multipart/form-data body needs its boundary")
    parts: dict[str, bytearray] = {}
    state: dict[str, Any] = {"field": b"", "headers": {}, "name": None, "data": None}

    def on_part_begin() -> None:
        state["headers"], state["name"], state["data"] = {}, None, bytearray()

    def on_header_field(data: bytes, start: int, end: int) -> None:
        state["field"] = data[start:end].lower()

    def on_header_value(data: bytes, start: int, end: int) -> None:
        state["headers"][state["field"]] = data[start:end]

    def on_part_data(data: bytes, start: int, end: int) -> None:
        state["data"] += data[start:end]

    def on_part_end() -> None:
        _, opts = parse_options_header(state["headers"].get(b"content-disposition", b""))
        name = opts.get(b"name", b"").decode("utf-8", "replace")
        if name in PARTS and name not in parts:
            parts[name] = state["data"]

    try:
        parser = MultipartParser(
            boundary,
            {
                "on_part_begin": on_part_begin,
                "on_header_field": on_header_field,
                "on_header_value": on_header_value,
                "on_part_data": on_part_data,
                "on_part_end": on_part_end,
            },
        )
        parser.write(body)
        parser.finalize()
    except Exception as exc:  # python-multipart's errors for a broken form are of many kinds
        return invalid("body", f"not a readable multipart/form-data body ({type(exc).__name__})")
    for name in PARTS:
        if name not in parts:
            return invalid(
                name, "missing: send the map's YAML as part 'yaml' and its image as part 'image'"
            )
    if len(parts["yaml"]) > MAX_YAML:
        return invalid("yaml", f"at most {MAX_YAML} bytes")
    try:
        params = parse_map_yaml(bytes(parts["yaml"]).decode("utf-8"))
        spec: MapImageSpec = inline_map(params, bytes(parts["image"]), name=str(params["image"]))
    except UnicodeDecodeError:
        return invalid("yaml", "not UTF-8 text")
    except MapError as exc:
        return invalid(exc.field, exc.message)
    except ValidationError as exc:
        return Invalid([_portable(dict(e)) for e in exc.errors(include_url=False)])
    except (RecursionError, TypeError, ValueError) as exc:  # YAML nested too deep, odd keys
        return invalid("yaml", f"not a map's parameters ({type(exc).__name__})")
    return _checked(MapImageSpec.model_validate(spec.model_dump(exclude={"known"})))


def stored_map(row: MapRow) -> StoredMap:
    """A stored map as a mission's validation and worker take it."""
    meta = row.meta
    params = MapParams(
        float(meta["resolution"]),
        (float(meta["origin"][0]), float(meta["origin"][1]), float(meta["origin"][2])),
        bool(meta.get("negate", 0)),
        float(meta.get("occupied_thresh", 0.65)),
        float(meta.get("free_thresh", 0.25)),
        meta.get("mode", "trinary"),
    )
    return StoredMap(row.id, params, bytes(row.image), row.name)


def stored_maps(store: Store, ids: list[str]) -> dict[str, StoredMap]:
    """The stored maps among ``ids`` (a store read: call it in a thread)."""
    return {map_id_: stored_map(row) for map_id_, row in store.maps(ids).items()}


def store_inline(store: Store, maps: list[tuple[InlineMapSpec, OccupancyRaster]]) -> list[str]:
    """Store a mission's inline maps (each once, by content hash): their ids, in order."""
    ids = []
    for spec, raster in maps:
        prepared = prepare(spec, raster)
        store.add_map(prepared.id, prepared.name, prepared.meta, prepared.image)
        ids.append(prepared.id)
    return ids


def image_base64(row: MapRow) -> str:
    return base64.b64encode(row.image).decode("ascii")


def render_cells(image: bytes, params: MapParams) -> bytes:
    """In a validation process: a stored map's classes as the viewer draws them, an RGBA PNG
    in the image's orientation (row 0 the top): occupied dark and opaque, unknown light and
    half transparent, free transparent."""
    import io

    import numpy as np
    from PIL import Image

    from app.settings import max_map_pixels
    from sim.maps import load_raster
    from sim.raster import OCCUPIED, UNKNOWN

    cells = load_raster(image, params, max_map_pixels()).cells.T[::-1]  # back to image rows
    rgba = np.zeros((*cells.shape, 4), dtype=np.uint8)
    rgba[cells == OCCUPIED] = (51, 51, 51, 255)
    rgba[cells == UNKNOWN] = (160, 160, 160, 90)
    out = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(rgba), mode="RGBA").save(out, format="PNG")
    return out.getvalue()

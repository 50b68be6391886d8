"""Occupancy-grid maps in a mission (docs/mission-format.md): the ROS ``map_server`` format,
inline or stored (``POST /maps``), decoded into ``sim.raster.OccupancyRaster``.

A map is the ``map_server`` YAML's parameters and its image (base64 in JSON). ``known: true``
maps are the planner's static layer; ``known: false`` maps are ground truth the robot must
sense, and must be binary. A stored map is named by its id (its content hash); a mission that
names one is validated with the map at hand: ``resolve`` asks whoever validates for the maps
(``MapsNeeded``) when the validation context does not hold them.
"""

from __future__ import annotations

import base64
import binascii
import hashlib
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import Discriminator, Field, Tag
from pydantic import Strict as StrictNumber

from app.missions.parts import Strict
from app.settings import max_map_pixels
from sim.maps import MapError, MapParams, image_size, load_raster
from sim.raster import UNKNOWN, OccupancyRaster

MAP_ID = r"^[0-9a-f]{32}$"
Threshold = Annotated[float, StrictNumber(), Field(allow_inf_nan=False, ge=0, le=1)]
Finite = Annotated[float, StrictNumber(), Field(allow_inf_nan=False, ge=-1e6, le=1e6)]


class MapImageSpec(Strict):
    """A map in ROS ``map_server``'s format: its YAML's parameters and its image."""

    image: Annotated[str, Field(min_length=1)]
    """the image file's bytes in base64: a binary PGM (P5, 8 or 16 bit) or a PNG; row 0 is
    the top of the map"""
    resolution: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, gt=0, le=100)]
    """metres per pixel"""
    origin: tuple[Finite, Finite, Finite] = (0.0, 0.0, 0.0)
    """[x, y, yaw]: the world pose of the lower-left pixel's outer corner (metres, radians
    counter-clockwise); cell centres lie at origin + R(yaw)·(i + ½, j + ½)·resolution"""
    negate: Annotated[int, Field(ge=0, le=1)] = 0
    """1: white is occupied and black free (p = shade instead of 1 - shade)"""
    occupied_thresh: Threshold = 0.65
    """p above this is occupied"""
    free_thresh: Threshold = 0.25
    """p below this is free (below occupied_thresh); between the two, unknown"""
    mode: Literal["trinary", "scale", "raw"] = "trinary"
    """map_server's mode: trinary (occupied, free, unknown), scale (a probability between the
    thresholds, a transparent pixel unknown), raw (the pixel value is the percentage)"""
    name: Annotated[str, Field(max_length=120, pattern=r"^[^\x00]*$")] = ""
    """a name for people (the YAML's file name when posted as files)"""

    def params(self) -> MapParams:
        return MapParams(
            self.resolution,
            (float(self.origin[0]), float(self.origin[1]), float(self.origin[2])),
            bool(self.negate),
            self.occupied_thresh,
            self.free_thresh,
            self.mode,
        )

    def image_bytes(self) -> bytes:
        """The image, decoded from base64 (``MapError`` naming ``image`` if it is not)."""
        try:
            return base64.b64decode(self.image, validate=True)
        except (binascii.Error, ValueError) as exc:
            raise MapError("image", "not valid base64") from exc


class InlineMapSpec(MapImageSpec):
    """A map given in the mission itself."""

    known: bool = True
    """true: the planner's static layer (its unknown cells are never observed); false: ground
    truth the robot must sense (binary: no cell between the thresholds)"""


class MapRefSpec(Strict):
    """A map stored by ``POST /maps``, named by its id."""

    id: Annotated[str, Field(pattern=MAP_ID)]
    """the map's id (``POST /maps`` answered it)"""
    known: bool = True
    """true: the planner's static layer; false: ground truth the robot must sense"""


def _kind(value: Any) -> str:
    if isinstance(value, MapRefSpec) or (isinstance(value, dict) and "id" in value):
        return "MapRefSpec"
    return "InlineMapSpec"


MapEntry = Annotated[
    Annotated[InlineMapSpec, Tag("InlineMapSpec")] | Annotated[MapRefSpec, Tag("MapRefSpec")],
    Discriminator(_kind),
]


@dataclass(frozen=True)
class StoredMap:
    """A stored map as validation needs it: its parameters and image file."""

    id: str
    params: MapParams
    image: bytes
    name: str = ""


class MapsNeeded(Exception):
    """Validating this mission needs the stored maps ``ids``: the validator (a validation
    process) hands this back, and the route validates again with them in the context. Not a
    ``ValueError``, so pydantic lets it through."""

    def __init__(self, ids: list[str]) -> None:
        super().__init__(", ".join(ids))
        self.ids = ids


def map_id(spec: MapImageSpec) -> str:
    """A map's content hash: its image bytes and the parameters that give them meaning (not
    its name): the same map posted twice is stored once."""
    digest = hashlib.sha256(spec.image_bytes()).hexdigest()
    params = spec.model_dump(exclude={"image", "name", "known"})
    text = json.dumps({"image": digest, **params}, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def decode_map(
    image: bytes | MapImageSpec, params: MapParams | None, known: bool, field: str, name: str = ""
) -> OccupancyRaster:
    """The raster of a map, its image file and parameters or an inline spec (``ValueError``
    "``field``.param: why" when it is bad; a hidden map must be binary)."""
    try:
        if isinstance(image, MapImageSpec):
            params, name, image = image.params(), image.name, image.image_bytes()
        assert params is not None
        raster = load_raster(image, params, max_map_pixels(), name)
    except MapError as exc:
        raise ValueError(f"{field}.{exc.field}: {exc.message}") from exc
    if not known:
        unknown = int((raster.cells == UNKNOWN).sum())
        if unknown:
            raise ValueError(
                f"{field}.known: a hidden map (known: false) must be binary, but {unknown} "
                "cells lie between free_thresh and occupied_thresh (unknown): give the truth"
            )
    return raster


def resolve(
    maps: list[InlineMapSpec | MapRefSpec], context: Any
) -> list[tuple[OccupancyRaster, bool]]:
    """Each map of a mission as (raster, known). Stored maps come from the validation
    context's ``maps`` (id -> ``StoredMap``); without one, ``MapsNeeded`` asks for them."""
    stored: Mapping[str, StoredMap] | None = None
    if isinstance(context, Mapping):
        stored = context.get("maps")
    refs = [m.id for m in maps if isinstance(m, MapRefSpec)]
    if refs and stored is None:
        raise MapsNeeded(sorted(set(refs)))
    out = []
    for k, entry in enumerate(maps):
        field = f"maps.{k}"
        if isinstance(entry, MapRefSpec):
            assert stored is not None
            found = stored.get(entry.id)
            if found is None:
                raise ValueError(f"{field}.id: no map {entry.id} (POST /maps stores one)")
            raster = decode_map(found.image, found.params, entry.known, field, found.name)
            out.append((raster, entry.known))
        else:
            out.append((decode_map(entry, None, entry.known, field), entry.known))
    return out


def referenced(request: Mapping[str, Any]) -> list[str]:
    """The ids of the stored maps a mission request names, in its order."""
    maps = request.get("maps") or []
    return [m["id"] for m in maps if isinstance(m, dict) and isinstance(m.get("id"), str)]


def union_extent(rasters: list[OccupancyRaster]) -> tuple[float, float, float, float]:
    """The world box covering every map: (xmin, xmax, ymin, ymax)."""
    boxes = [r.extent() for r in rasters]
    return (
        min(b[0] for b in boxes),
        max(b[1] for b in boxes),
        min(b[2] for b in boxes),
        max(b[3] for b in boxes),
    )


def read_map_yaml(path: Path, known: bool = True) -> InlineMapSpec:
    """A map_server map from its YAML file (its ``image`` relative to the YAML, as
    map_server reads it) as an inline map (``MapError`` naming the parameter)."""
    try:
        text = path.read_text()
    except OSError as exc:
        raise MapError("yaml", f"{path}: cannot read ({exc.strerror})") from exc
    params = parse_map_yaml(text)
    image_name = params.pop("image")
    image_path = Path(image_name)
    if not image_path.is_absolute():
        image_path = path.parent / image_path
    try:
        image = image_path.read_bytes()
    except OSError as exc:
        raise MapError("image", f"{image_path}: cannot read ({exc.strerror})") from exc
    return inline_map(params, image, known, name=path.name)


def parse_map_yaml(text: str) -> dict[str, Any]:
    """A map_server YAML's parameters (``image`` among them), checked for their types
    (``MapError`` naming the key); unknown keys are an error, as anywhere in the API."""
    import yaml

    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise MapError("yaml", f"not valid YAML ({exc.__class__.__name__})") from exc
    if not isinstance(data, dict):
        raise MapError("yaml", "a map's YAML is a mapping of its parameters")
    allowed = {"image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode"}
    for key in data:
        if key not in allowed:
            raise MapError(str(key), f"not a map_server parameter ({', '.join(sorted(allowed))})")
    if not isinstance(data.get("image"), str) or not data["image"]:
        raise MapError("image", "the YAML names its image file (image: office.pgm)")
    if "resolution" not in data:
        raise MapError("resolution", "missing (metres per pixel)")
    return dict(data)


def inline_map(
    params: Mapping[str, Any], image: bytes, known: bool = True, name: str = ""
) -> InlineMapSpec:
    """An inline map from YAML parameters and image bytes (pydantic checks the parameters;
    its errors name them). ``image`` of the parameters, if any, is ignored."""
    data = {k: v for k, v in params.items() if k != "image"}
    origin = data.get("origin")
    if isinstance(origin, list | tuple) and any(
        isinstance(v, float) and not math.isfinite(v) for v in origin
    ):
        raise MapError("origin", f"need three finite numbers, got {list(origin)}")
    image_size(image)  # the magic, before anything else
    return InlineMapSpec.model_validate(
        {**data, "image": base64.b64encode(image).decode("ascii"), "known": known, "name": name}
    )

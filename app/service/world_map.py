"""A mission's world model as a map, the way ROS's map_saver writes one: a YAML and a PGM.

The worker keeps, with the mission's saved state (about once a second and at its end), the
world model's cells as map_server classes: occupied where the lethal view is (known obstacles
and maps, sensed occupancy), free where the robot observed (or a known map says free), unknown
elsewhere; compressed (``pack``). The API writes them as map_saver's files (``pgm``, ``yaml``):
``GET /missions/{id}/world.yaml`` and ``world.pgm``, which map_server (and ``POST /maps``) read
back as the same cells.
"""

from __future__ import annotations

import base64
import zlib
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from sim.maps import encode_pgm
from sim.raster import FREE, OCCUPIED, UNKNOWN

# map_saver's YAML: its unknown shade 205 reads p = 0.196 (free below it, occupied over 0.65)
OCCUPIED_THRESH, FREE_THRESH = 0.65, 0.196
LEVEL = 6  # zlib: the classes of a 200 x 200 grid pack into a few kilobytes


class WorldCells(Protocol):
    """What the map reads of a world model (``domain.world.WorldModel``)."""

    def occupied(self) -> NDArray[np.bool_]: ...

    def observed(self) -> NDArray[np.bool_]: ...


def classes(world: WorldCells) -> NDArray[np.int8]:
    """The world model's cells ``[nx, ny]`` as map_server classes."""
    occupied, observed = world.occupied(), world.observed()
    out = np.where(observed, FREE, UNKNOWN).astype(np.int8)
    out[occupied] = OCCUPIED
    return out


def pack(world: WorldCells, origin: list[float], resolution: float) -> dict[str, Any]:
    """The map as the mission's state keeps it: origin (the lower-left corner), resolution,
    size and the classes, zlib-compressed and in base64."""
    cells = classes(world)
    nx, ny = cells.shape
    data = base64.b64encode(zlib.compress(cells.tobytes(), LEVEL)).decode("ascii")
    return {"origin": list(origin), "resolution": resolution, "size": [nx, ny], "cells": data}


def unpack(packed: dict[str, Any]) -> NDArray[np.int8]:
    """The classes ``[nx, ny]`` of a packed map."""
    nx, ny = (int(v) for v in packed["size"])
    raw = zlib.decompress(base64.b64decode(packed["cells"]))
    return np.frombuffer(raw, dtype=np.int8).reshape(nx, ny)


def pgm(packed: dict[str, Any]) -> bytes:
    """map_saver's image of a packed map (8-bit PGM: occupied 0, free 254, unknown 205)."""
    return encode_pgm(unpack(packed))


def yaml(packed: dict[str, Any], image: str) -> str:
    """map_saver's YAML of a packed map, its image named ``image`` (relative to the YAML)."""
    x, y = (float(v) for v in packed["origin"])
    return (
        f"image: {image}\n"
        "mode: trinary\n"
        f"resolution: {float(packed['resolution']):g}\n"
        f"origin: [{x:g}, {y:g}, 0]\n"
        "negate: 0\n"
        f"occupied_thresh: {OCCUPIED_THRESH:g}\n"
        f"free_thresh: {FREE_THRESH:g}\n"
    )

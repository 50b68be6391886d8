"""Maps made by the tests: map_server images (PGM, PNG) and missions on them."""

from __future__ import annotations

import base64
import io

import numpy as np
from numpy.typing import NDArray

FREE, OCCUPIED, UNKNOWN = 254, 0, 205  # map_saver's shades


def pgm(pixels: NDArray[np.integer], maxval: int = 255) -> bytes:
    """A binary PGM (P5) of ``pixels`` ``[h, w]`` (row 0 the top); 16 bit past 255."""
    h, w = pixels.shape
    body = pixels.astype(">u2" if maxval > 255 else np.uint8).tobytes()
    return b"P5\n# made by a test\n%d %d\n%d\n" % (w, h, maxval) + body


def png(pixels: NDArray[np.integer], mode: str = "L") -> bytes:
    """A PNG of ``pixels`` (``[h, w]`` grey, or ``[h, w, c]``) in Pillow's ``mode``."""
    from PIL import Image

    out = io.BytesIO()
    if mode == "I;16":
        image = Image.fromarray(np.asarray(pixels, dtype=np.uint16))
    else:
        image = Image.fromarray(np.asarray(pixels, dtype=np.uint8)).convert(mode)
    image.save(out, format="PNG")
    return out.getvalue()


def b64(data: bytes) -> str:
    return base64.b64encode(data).decode("ascii")


def office(unknown_band: bool = True) -> NDArray[np.uint8]:
    """A 6 m x 4 m room at 0.05 m (120 x 80 pixels): walls all round, a wall across the
    middle (x from -0.1 to 0.1 m with the origin at (-3, -2)) with a 1 m door at y in
    (-0.5, 0.5), and a band of unknown cells in the north-east corner."""
    img = np.full((80, 120), FREE, np.uint8)
    img[:, 58:62] = OCCUPIED
    img[30:50, 58:62] = FREE  # the door: rows 30-49 from the top, y in (-0.5, 0.5)
    img[:2, :] = OCCUPIED
    img[-2:, :] = OCCUPIED
    img[:, :2] = OCCUPIED
    img[:, -2:] = OCCUPIED
    if unknown_band:
        img[5:15, 80:100] = UNKNOWN
    return img


OFFICE_ORIGIN = [-3.0, -2.0, 0.0]
OFFICE_YAML = "image: office.pgm\nresolution: 0.05\norigin: [-3.0, -2.0, 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n"
# From the east half to the west half, through the door.
OFFICE_MISSION = {
    "name": "office",
    "start": {"x": 1.5, "y": 1.0, "psi": 0.0},
    "goals": [{"x": -2.0, "y": 1.0, "tolerance": 0.15}],
}


def office_map(known: bool = True, unknown_band: bool = True) -> dict[str, object]:
    """The office as a mission's inline map (JSON form)."""
    return {
        "image": b64(pgm(office(unknown_band))),
        "resolution": 0.05,
        "origin": OFFICE_ORIGIN,
        "free_thresh": 0.196,
        "known": known,
    }

"""Reading ROS ``map_server`` maps: a PGM (P5, 8 or 16 bit) or PNG image and its parameters
into an ``OccupancyRaster``, with ``map_server``'s meaning.

- The image's row 0 is the top of the map; ``origin`` is the world pose of the lower-left
  pixel's outer corner, so cell centres lie at origin + R(yaw)·(i + ½, j + ½)·resolution.
- A pixel's shade is the mean of its colour channels (not luma), in trinary mode with the
  alpha channel (opacity) averaged in, as ``map_server`` does; ``p = 1 - shade`` (for 8 bits,
  (255 - v) / 255), or ``shade`` itself when ``negate``.
- ``trinary``: p > ``occupied_thresh`` occupied, p < ``free_thresh`` free, else unknown.
  ``scale``: the same, a pixel that is not opaque unknown, and between the thresholds a
  probability (1-99, unknown to the raster's three classes). ``raw``: the pixel value (0-255,
  ``negate`` ignored, as Nav2's ``map_io``) is the occupancy percentage; over 100 unknown; the
  raster's classes apply the thresholds to it.

PGM is parsed here (every ``maxval`` up to 65535, exactly); PNG through Pillow, whose size is
checked before any pixel is decoded (a small file can hold a huge image).
"""

from __future__ import annotations

import io
import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from sim.raster import FREE, OCCUPIED, UNKNOWN, OccupancyRaster

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
MODES = ("trinary", "scale", "raw")
Mode = Literal["trinary", "scale", "raw"]


class MapError(ValueError):
    """A map that cannot be used: ``field`` names the parameter at fault (``image``,
    ``resolution``, ``origin``, ``occupied_thresh``, ...), the message says why."""

    def __init__(self, field: str, message: str) -> None:
        super().__init__(f"{field}: {message}")
        self.field = field
        self.message = message


@dataclass(frozen=True)
class MapParams:
    """A map's YAML parameters, as ``map_server`` reads them."""

    resolution: float
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    negate: bool = False
    occupied_thresh: float = 0.65
    free_thresh: float = 0.25
    mode: Mode = "trinary"

    def check(self) -> None:
        """Raise ``MapError`` naming the first parameter out of its range."""
        if not (math.isfinite(self.resolution) and self.resolution > 0):
            raise MapError(
                "resolution", f"must be positive (metres per pixel), got {self.resolution}"
            )
        if len(self.origin) != 3 or not all(math.isfinite(v) for v in self.origin):
            raise MapError(
                "origin", f"need [x, y, yaw], three finite numbers, got {list(self.origin)}"
            )
        for name in ("occupied_thresh", "free_thresh"):
            value = getattr(self, name)
            if not (math.isfinite(value) and 0.0 <= value <= 1.0):
                raise MapError(name, f"must lie in [0, 1], got {value}")
        if not self.free_thresh < self.occupied_thresh:
            raise MapError(
                "free_thresh",
                f"must be below occupied_thresh ({self.free_thresh} >= {self.occupied_thresh})",
            )
        if self.mode not in MODES:
            raise MapError("mode", f"one of {', '.join(MODES)}, got {self.mode!r}")


@dataclass(frozen=True)
class Pixels:
    """A decoded image: colour channels ``[h, w, c]`` as shades in [0, 1] (row 0 the top),
    the opacity ``[h, w]`` in [0, 1] when it has an alpha channel, and the raw values of the
    first channel (for ``raw`` mode)."""

    colour: NDArray[np.float64]
    alpha: NDArray[np.float64] | None
    raw: NDArray[np.float64]
    format: str  # "pgm" or "png"
    depth: int  # bits per channel


def image_size(data: bytes) -> tuple[str, int, int]:
    """The format and ``(width, height)`` of a PGM or PNG image, from its header alone."""
    if data.startswith(PNG_MAGIC):
        if len(data) < 24 or data[12:16] != b"IHDR":
            raise MapError("image", "a PNG without its header (IHDR)")
        width = int.from_bytes(data[16:20], "big")
        height = int.from_bytes(data[20:24], "big")
        return "png", width, height
    if data.startswith(b"P5"):
        width, height, _, _ = _pgm_header(data)
        return "pgm", width, height
    head = data[:8]
    raise MapError(
        "image",
        f"not a PGM (P5) or PNG image (it starts with {head!r}); map_server maps are binary "
        "PGM or PNG",
    )


def _pgm_header(data: bytes) -> tuple[int, int, int, int]:
    """Width, height, maxval and the offset of the pixels of a binary PGM (P5)."""
    fields: list[int] = []
    pos = 2
    while len(fields) < 3:
        # whitespace and comments, then a decimal number
        while pos < len(data) and (data[pos : pos + 1].isspace() or data[pos : pos + 1] == b"#"):
            if data[pos : pos + 1] == b"#":
                end = data.find(b"\n", pos)
                pos = len(data) if end < 0 else end + 1
            else:
                pos += 1
        start = pos
        while pos < len(data) and data[pos : pos + 1].isdigit():
            pos += 1
        if start == pos or pos - start > 9:
            raise MapError("image", "a PGM (P5) header needs width, height and maxval")
        fields.append(int(data[start:pos]))
    if pos >= len(data) or not data[pos : pos + 1].isspace():
        raise MapError("image", "a PGM (P5) header ends with one whitespace before the pixels")
    width, height, maxval = fields
    if width <= 0 or height <= 0:
        raise MapError("image", f"a PGM of {width} x {height} pixels has no cells")
    if not 0 < maxval <= 65535:
        raise MapError("image", f"PGM maxval must lie in 1..65535, got {maxval}")
    return width, height, maxval, pos + 1


def decode(data: bytes, max_pixels: int) -> Pixels:
    """The pixels of a PGM (P5) or PNG image of at most ``max_pixels`` pixels (``MapError``
    otherwise, before decoding)."""
    kind, width, height = image_size(data)
    if width <= 0 or height <= 0:
        raise MapError("image", f"an image of {width} x {height} pixels has no cells")
    if width * height > max_pixels:
        raise MapError(
            "image",
            f"{width} x {height} = {width * height} pixels; at most {max_pixels} "
            "(SCREWSNAKE_MAX_MAP_PIXELS)",
        )
    if kind == "pgm":
        return _decode_pgm(data)
    return _decode_png(data)


def _decode_pgm(data: bytes) -> Pixels:
    width, height, maxval, offset = _pgm_header(data)
    dtype = np.dtype(">u2") if maxval > 255 else np.dtype(np.uint8)
    need = width * height * dtype.itemsize
    body = data[offset : offset + need]
    if len(body) < need:
        raise MapError("image", f"the PGM is cut short: {len(body)} of {need} bytes of pixels")
    values = np.frombuffer(body, dtype=dtype).reshape(height, width).astype(float)
    if np.any(values > maxval):
        raise MapError("image", f"PGM pixels above its maxval {maxval}")
    return Pixels((values / maxval)[..., None], None, values, "pgm", 16 if maxval > 255 else 8)


def _decode_png(data: bytes) -> Pixels:
    from PIL import Image  # only maps need Pillow

    try:
        with Image.open(io.BytesIO(data)) as opened:
            opened.load()
            im: Image.Image = opened
            mode = im.mode
            if mode == "1":
                im, mode = im.convert("L"), "L"
            elif mode == "P":
                target = "RGBA" if "transparency" in im.info else "RGB"
                im, mode = im.convert(target), target
            elif mode == "PA":
                im, mode = im.convert("RGBA"), "RGBA"
            array = np.asarray(im)
    except MapError:
        raise
    except Exception as exc:  # Pillow's errors for a broken file are of many kinds
        raise MapError("image", f"not a readable PNG ({type(exc).__name__}: {exc})") from exc
    if mode in ("I;16", "I;16B", "I;16L", "I"):
        values = np.clip(array.astype(float), 0, 65535)
        return Pixels((values / 65535.0)[..., None], None, values, "png", 16)
    if mode not in ("L", "LA", "RGB", "RGBA"):
        raise MapError(
            "image", f"PNG colour mode {mode} is not a map (grey, grey+alpha, RGB, RGBA)"
        )
    values = array.astype(float)
    if values.ndim == 2:
        values = values[..., None]
    has_alpha = mode in ("LA", "RGBA")
    colour = values[..., :-1] if has_alpha else values
    alpha = values[..., -1] / 255.0 if has_alpha else None
    return Pixels(colour / 255.0, alpha, colour[..., 0], "png", 8)


def classify(pixels: Pixels, params: MapParams) -> tuple[NDArray[np.int8], NDArray[np.int8]]:
    """Per pixel (row 0 the top): the raster class (``OCCUPIED``, ``FREE``, ``UNKNOWN``) and
    the value ``map_server`` puts in its occupancy grid (100, 0, -1, or 1-99 in scale mode)."""
    colour = pixels.colour
    occ_th, free_th = params.occupied_thresh, params.free_thresh
    if params.mode == "raw":
        percent = np.rint(pixels.raw)
        known = percent <= 100
        value = np.where(known, percent, -1).astype(np.int8)
        p = percent / 100.0
        cls = np.where(
            ~known, UNKNOWN, np.where(p > occ_th, OCCUPIED, np.where(p < free_th, FREE, UNKNOWN))
        )
        return cls.astype(np.int8), value
    if params.mode == "trinary" and pixels.alpha is not None:
        channels = colour.shape[-1] + 1
        shade = (colour.sum(axis=-1) + pixels.alpha) / channels
    else:
        shade = colour.mean(axis=-1)
    p = shade if params.negate else 1.0 - shade
    occupied, free = p > occ_th, p < free_th
    cls = np.where(occupied, OCCUPIED, np.where(free, FREE, UNKNOWN)).astype(np.int8)
    if params.mode == "trinary":
        value = np.where(occupied, 100, np.where(free, 0, -1)).astype(np.int8)
        return cls, value
    # scale: a pixel that is not opaque is unknown; between the thresholds, a probability
    ratio = np.rint((p - free_th) / (occ_th - free_th) * 100.0)
    value = np.where(occupied, 100, np.where(free, 0, np.clip(ratio, 1, 99))).astype(np.int8)
    if pixels.alpha is not None:
        clear = pixels.alpha < 1.0
        value = np.where(clear, -1, value).astype(np.int8)
        cls = np.where(clear, UNKNOWN, cls).astype(np.int8)
    return cls, value


def load_raster(data: bytes, params: MapParams, max_pixels: int, name: str = "") -> OccupancyRaster:
    """A map_server map (image bytes and parameters) as a raster (``MapError`` if it is bad)."""
    params.check()
    pixels = decode(data, max_pixels)
    cls, _ = classify(pixels, params)
    # image row 0 is the top: the raster's j = 0 is the image's last row; i is the column
    cells = np.ascontiguousarray(cls[::-1, :].T)
    return OccupancyRaster(cells, params.resolution, params.origin, name)


def encode_pgm(cells: NDArray[np.int8]) -> bytes:
    """A raster's classes ``[nx, ny]`` as map_saver writes them: an 8-bit PGM, occupied 0,
    free 254, unknown 205, row 0 the top."""
    shade = np.where(cells == OCCUPIED, 0, np.where(cells == FREE, 254, 205)).astype(np.uint8)
    image = np.ascontiguousarray(shade.T[::-1, :])
    h, w = image.shape
    return b"P5\n%d %d\n255\n" % (w, h) + image.tobytes()

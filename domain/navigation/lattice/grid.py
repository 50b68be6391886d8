"""Where the lattice's states lie: centroid cells over the arena and headings, numbered.

A state is the cell of the body centroid (every shape turns in place about it) and one of
``orientations`` headings; its number is ``(k * nx + i) * ny + j``. The cells are the
costmap's: the same origin and resolution, so a motion's swept cells are the costmap's cells.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from domain.navigation.settings import NavigationSettings
from sim.robot import Array, rotate
from sim.world import Bounds

Key = tuple[int, int, int]  # centroid cell (i, j) and orientation bin k


def compose(pose: Array, delta: Array) -> Array:
    """``pose ∘ delta`` for poses ``[..., 3]``: ``delta`` expressed in ``pose``'s frame."""
    xy = pose[..., :2] + rotate(delta[..., :2], pose[..., 2])
    return np.concatenate([xy, (pose[..., 2] + delta[..., 2])[..., None]], axis=-1)


def relative(pose: Sequence[float] | Array, target: Sequence[float] | Array) -> Array:
    """``pose⁻¹ ∘ target``: where ``target`` lies in the frame of ``pose`` (both ``[3]``).
    On floats: called at every move, where numpy's calls on three numbers cost more than
    the arithmetic."""
    px, py, pw = (float(v) for v in pose)
    tx, ty, tw = (float(v) for v in target)
    c, s = math.cos(-pw), math.sin(-pw)
    dx, dy = tx - px, ty - py
    return np.array([c * dx - s * dy, s * dx + c * dy, math.remainder(tw - pw, 2 * math.pi)])


@dataclass(frozen=True)
class LatticeGrid:
    """``nx × ny`` centroid cells over the arena, ``orientations`` headings each."""

    bounds: Bounds
    settings: NavigationSettings

    def __reduce__(self) -> tuple[type[LatticeGrid], tuple[Bounds, NavigationSettings]]:
        """Pickled as its bounds and settings: the cached arrays below (every cell's centre:
        most of a plan version's stored source) are made again where they are read."""
        return LatticeGrid, (self.bounds, self.settings)

    # Cached: searches ask for these on every state they touch.
    @cached_property
    def nx(self) -> int:
        r = self.settings.resolution
        return max(1, math.ceil((self.bounds.xmax - self.bounds.xmin) / r - 1e-9))

    @cached_property
    def ny(self) -> int:
        r = self.settings.resolution
        return max(1, math.ceil((self.bounds.ymax - self.bounds.ymin) / r - 1e-9))

    @cached_property
    def centres(self) -> Array:
        """Every cell centre ``[nx * ny, 2]``, cell (i, j) at row ``i * ny + j``."""
        r = self.settings.resolution
        xs = self.bounds.xmin + (np.arange(self.nx) + 0.5) * r
        ys = self.bounds.ymin + (np.arange(self.ny) + 0.5) * r
        cx, cy = np.meshgrid(xs, ys, indexing="ij")
        out: Array = np.stack([cx.ravel(), cy.ravel()], -1)
        return out

    def centre(self, i: int, j: int) -> Array:
        return np.array(self.centre_xy(i, j))

    def centre_xy(self, i: int, j: int) -> tuple[float, float]:
        """Cell (i, j)'s centre as two floats (no array, for per-state loops)."""
        r = self.settings.resolution
        return self.bounds.xmin + (i + 0.5) * r, self.bounds.ymin + (j + 0.5) * r

    def cell(self, x: float, y: float) -> tuple[int, int]:
        r = self.settings.resolution
        i = min(self.nx - 1, max(0, math.floor((x - self.bounds.xmin) / r)))
        j = min(self.ny - 1, max(0, math.floor((y - self.bounds.ymin) / r)))
        return i, j

    def inside(self, i: int, j: int) -> bool:
        return 0 <= i < self.nx and 0 <= j < self.ny

    def encode(self, key: Key) -> int:
        i, j, k = key
        return (k * self.nx + i) * self.ny + j

    def decode(self, number: int) -> Key:
        rest, j = divmod(number, self.ny)
        k, i = divmod(rest, self.nx)
        return i, j, k

    @cached_property
    def size(self) -> int:
        return self.nx * self.ny * self.settings.orientations

    @property
    def plane(self) -> int:
        """States per orientation (cells)."""
        return self.nx * self.ny

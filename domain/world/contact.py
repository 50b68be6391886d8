"""Contact evidence: where a bumper's report says something is, as a soft, fading layer.

The Robot port reports which part touched (0 = head, 1-4 = units) and on which side of it, as a
stall-current sensor or a side bumper would: not where along the part. A contact is therefore
one obstacle somewhere just outside that side (``touched_side``: along the whole side of a unit,
or round its rounded end): its evidence is one expected obstacle shared by the cells there, as
a cone's hit is shared by the cells of its arc. Beams that see some of those cells free, or the
body covering them, leave the obstacle in the others (their share grows: the head looking past
the tail's corner does not make what the tail touched go away, it narrows where it is); a
contact whose every cell was seen free is gone. Evidence fades with model time
(``contact_half_life``). It raises the cost of sweeping there blind (``domain.navigation``) and
never makes a cell lethal: a contact spread across a real gap a little wider than the body
would otherwise close it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from domain.world.grid import Flat, Grid, unique_cells
from domain.world.settings import CostmapSettings
from sim.robot import DEFAULT_GEOMETRY, Array, RobotGeometry, joint_positions

SIDES = ("front", "rear", "left", "right")
FADE_STEPS = 8  # fading is applied in this many steps per half-life (each a new version)
SPACING = 0.025  # metres between the points a touched side is laid out at
FORGOTTEN = 0.01  # a contact whose evidence fell below this is dropped
CAP_SPREAD = math.radians(75)  # an end bumper feels its rounded end within this of the axis


def touched_side(
    pose: tuple[float, float, float],
    joints: tuple[float, float, float],
    part: int,
    side: str,
    settings: CostmapSettings,
    geometry: RobotGeometry = DEFAULT_GEOMETRY,
) -> Array:
    """World points ``[N, 2]`` just outside ``side`` of ``part`` of the body at ``pose`` with
    ``joints``: where what it touched may be. A side runs along its part's length plus
    ``contact_extent`` at each end; an end (front, rear) round its rounded end."""
    if side not in SIDES:
        raise ValueError(f"contact side: one of {', '.join(SIDES)}, got {side!r}")
    if not 0 <= part <= 4:
        raise ValueError(f"contact part: 0 (head) to 4, got {part}")
    x, y, psi = pose
    pts = joint_positions(np.array([x, y, psi]), np.asarray(joints, dtype=float), geometry)
    if part == 0:
        ahead = np.array([-math.cos(psi), -math.sin(psi)])  # the head leads: against e(ψ)
        front, rear, radius = pts[0] + geometry.head_length * ahead, pts[0], geometry.head_radius
    else:
        front, rear, radius = pts[part - 1], pts[part], geometry.unit_radius
    axis = front - rear
    forward = axis / max(float(np.linalg.norm(axis)), 1e-9)
    left = np.array([-forward[1], forward[0]])
    reach = radius + settings.contact_standoff
    if side in ("front", "rear"):
        end, out = (front, forward) if side == "front" else (rear, -forward)
        sideways = np.array([-out[1], out[0]])
        n = max(3, math.ceil(2 * CAP_SPREAD * reach / SPACING) + 1)
        angles = np.linspace(-CAP_SPREAD, CAP_SPREAD, n)
        arc: Array = end + reach * (
            np.cos(angles)[:, None] * out + np.sin(angles)[:, None] * sideways
        )
        return arc
    outward = left if side == "left" else -left
    centre = (front + rear) / 2 + reach * outward
    half = float(np.linalg.norm(axis)) / 2 + settings.contact_extent
    steps = np.linspace(-half, half, max(2, math.ceil(2 * half / SPACING) + 1))
    line: Array = centre + steps[:, None] * forward
    return line


@dataclass
class _Touch:
    """One contact: its cells, which of them sensing has not seen free, when it happened."""

    cells: Flat
    live: NDArray[np.bool_]
    t: float
    weight: float = 1.0  # how much of its evidence is left (fading)


class ContactEvidence:
    """The contacts the robot felt, as a probability per cell (``probability``) and as
    log P(free) (``log_free``)."""

    def __init__(self, grid: Grid, settings: CostmapSettings) -> None:
        self.grid, self.settings = grid, settings
        self._touches: list[_Touch] = []
        self._faded_at: float | None = None  # model time of the last fading step
        self.version = 0  # counts changes
        self._grids: tuple[int, Array, Array] | None = None  # version, log P(free), P

    @property
    def any(self) -> bool:
        return bool(self._touches)

    def add(self, points: Array, t: float) -> bool:
        """A contact somewhere at the cells holding ``points``; whether any lies on the grid."""
        flat, inside = self.grid.locate(np.asarray(points, dtype=float).reshape(-1, 2))
        cells = unique_cells(flat[inside])
        if not cells.size:
            return False
        self._touches.append(_Touch(cells, np.ones(cells.size, dtype=bool), t))
        if self._faded_at is None:
            self._faded_at = t
        self.version += 1
        return True

    def clear(self, cells: Flat) -> bool:
        """``cells`` (flat) were seen free or lie under the body: what was touched is in the
        other cells of each contact; a contact with none left is gone. Whether any changed."""
        if not self._touches or not cells.size:
            return False
        changed = False
        kept = []
        for touch in self._touches:
            hit = touch.live & np.isin(touch.cells, cells)
            if hit.any():
                touch.live &= ~hit
                changed = True
            if touch.live.any():
                kept.append(touch)
        self._touches = kept
        if changed:
            self.version += 1
        return changed

    def fade(self, t: float) -> bool:
        """Fade the evidence to model time ``t`` in steps of ``FADE_STEPS`` per half-life (a step
        changes every contact: a new version of the layer); whether it changed."""
        if not self._touches or self._faded_at is None:
            self._faded_at = t
            return False
        step = self.settings.contact_half_life / FADE_STEPS
        steps = math.floor((t - self._faded_at) / step)
        if steps <= 0:
            return False
        self._faded_at += steps * step
        for touch in self._touches:
            touch.weight *= 0.5 ** (steps / FADE_STEPS)
        self._touches = [touch for touch in self._touches if touch.weight >= FORGOTTEN]
        self.version += 1
        return True

    def _layers(self) -> tuple[Array, Array]:
        if self._grids is None or self._grids[0] != self.version:
            log_free = np.zeros(self.grid.nx * self.grid.ny)
            for touch in self._touches:
                live = touch.cells[touch.live]
                share = touch.weight * self.settings.contact_probability / live.size
                # one expected obstacle (a contact is certain) shared by the live cells
                np.add.at(log_free, live, math.log1p(-min(share, 1.0 - 1e-6)))
            grid = log_free.reshape(self.grid.shape)
            self._grids = (self.version, grid, -np.expm1(grid))
        return self._grids[1], self._grids[2]

    def log_free(self) -> Array:
        """log P(free) per cell from the evidence alone (0 where there is none; read only)."""
        return self._layers()[0]

    @property
    def probability(self) -> Array:
        """P(occupied) per cell from the evidence alone (read only)."""
        return self._layers()[1]

    def cells(self) -> Flat:
        """The cells with evidence, sorted (flat indices)."""
        if not self._touches:
            return np.zeros(0, dtype=np.intp)
        return unique_cells(np.concatenate([t.cells[t.live] for t in self._touches]))

    def sources(self) -> NDArray[np.bool_]:
        """The cells where something touched may be (every live cell of a contact): where an
        obstacle is taken to go on from."""
        out = np.zeros(self.grid.nx * self.grid.ny, dtype=bool)
        for touch in self._touches:
            out[touch.cells[touch.live]] = True
        return out.reshape(self.grid.shape)

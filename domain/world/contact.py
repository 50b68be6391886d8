"""Contact evidence: where a bumper's report says something probably is, as a soft, fading layer.

The Robot port reports which part touched (0 = head, 1-4 = units) and on which side of it, as a
stall-current sensor or a side bumper would: not where along the part. So the evidence is spread
along the whole touched side, a probability per cell (``contact_probability``) just outside the
part's surface, combined with what the cell held before as independent evidence (noisy-or).
It raises the cost of sweeping there blind and never makes a cell lethal: a contact line that
ran across a real gap a little wider than the body would otherwise close it. Beams that see a
cell free, and the body covering it, clear its evidence at once; the rest fades with model time
(``contact_half_life``).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from domain.world.grid import Flat, Grid, unique_cells
from domain.world.settings import CostmapSettings
from sim.robot import DEFAULT_GEOMETRY, Array, RobotGeometry, joint_positions

SIDES = ("front", "rear", "left", "right")
FADE_STEPS = 8  # fading is applied in this many steps per half-life (each a new version)


def touched_side(
    pose: tuple[float, float, float],
    joints: tuple[float, float, float],
    part: int,
    side: str,
    settings: CostmapSettings,
    geometry: RobotGeometry = DEFAULT_GEOMETRY,
) -> Array:
    """World points ``[N, 2]`` (2.5 cm apart) just outside ``side`` of ``part`` of the body at
    ``pose`` with ``joints``: where what it touched may be. A side spans its part's length plus
    ``contact_extent`` at each end; an end (front, rear) spans the part's width."""
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
        sign = 1.0 if side == "front" else -1.0
        centre = (front if sign > 0 else rear) + sign * reach * forward
        along, half = left, radius
    else:
        outward = left if side == "left" else -left
        centre = (front + rear) / 2 + reach * outward
        along, half = forward, float(np.linalg.norm(axis)) / 2 + settings.contact_extent
    steps = np.linspace(-half, half, max(2, math.ceil(2 * half / 0.025) + 1))
    out: Array = centre + steps[:, None] * along
    return out


class ContactEvidence:
    """Per cell, the probability that it holds something a bumper touched (0: no evidence)."""

    def __init__(self, grid: Grid, settings: CostmapSettings) -> None:
        self.grid, self.settings = grid, settings
        self.probability = np.zeros(grid.shape)
        self._cells: set[int] = set()  # cells with evidence (few: fading touches only them)
        self._faded_at: float | None = None  # model time of the last fading step
        self.version = 0  # counts changes

    @property
    def any(self) -> bool:
        return bool(self._cells)

    def cells(self) -> Flat:
        """The cells with evidence, sorted (flat indices)."""
        return np.array(sorted(self._cells), dtype=np.intp)

    def add(self, points: Array, t: float) -> bool:
        """Evidence at the cells holding ``points`` (each cell once); whether any changed."""
        flat, inside = self.grid.locate(np.asarray(points, dtype=float).reshape(-1, 2))
        cells = unique_cells(flat[inside])
        if not cells.size:
            return False
        p = self.probability.reshape(-1)
        q = self.settings.contact_probability
        p[cells] = 1.0 - (1.0 - p[cells]) * (1.0 - q)  # independent evidence (noisy-or)
        self._cells.update(cells.tolist())
        self.version += 1
        if self._faded_at is None:
            self._faded_at = t
        return True

    def clear(self, cells: Flat) -> bool:
        """No evidence at ``cells`` (seen free, or under the body); whether any was."""
        if not self._cells or not cells.size:
            return False
        p = self.probability.reshape(-1)
        had = cells[p[cells] > 0.0]
        if not had.size:
            return False
        p[had] = 0.0
        self._cells.difference_update(had.tolist())
        self.version += 1
        return True

    def fade(self, t: float) -> bool:
        """Fade the evidence to model time ``t`` in steps of ``FADE_STEPS`` per half-life (a step
        changes every evidence cell: a new version of the layer); whether it changed."""
        if not self._cells or self._faded_at is None:
            self._faded_at = t
            return False
        step = self.settings.contact_half_life / FADE_STEPS
        steps = math.floor((t - self._faded_at) / step)
        if steps <= 0:
            return False
        self._faded_at += steps * step
        cells = self.cells()
        p = self.probability.reshape(-1)
        p[cells] *= 0.5 ** (steps / FADE_STEPS)
        gone = cells[p[cells] < 0.01]  # below 1 %: no evidence left worth its cells
        p[gone] = 0.0
        self._cells.difference_update(gone.tolist())
        self.version += 1
        return True

    def strong(self) -> NDArray[np.bool_]:
        """The cells whose evidence is at least half a contact's (what touched is there more
        likely than not, nearly): where an obstacle is taken to go on from."""
        out: NDArray[np.bool_] = self.probability >= 0.5 * self.settings.contact_probability
        return out

    def log_free(self) -> NDArray[np.float64]:
        """log P(free) per cell from the evidence alone (0 where there is none; a new array)."""
        out: NDArray[np.float64] = np.log1p(-self.probability)
        return out

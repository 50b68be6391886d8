"""The sensed occupancy layer: a log-odds grid updated by range readings (ray clearing, cone hits).

Clearing before marking: every reading first clears the cells its ray or cone swept, up to the
measured range minus a noise margin (2σ + half a cell; a reading of "nothing within range" clears
the cone to ``max_range`` minus the same margin, since an obstacle just inside the range may read
as out of it). Then the hit is placed where it may be: across the cone, over the measured range
± 2σ. A cone's one reading is the nearest hit anywhere in the cone, so that region only says "at
least one of these cells is occupied". Its evidence (``log_odds_hit`` in all) is shared across the
region's cells in proportion to range likelihood x current occupancy probability, so cells other
beams cleared get little and cells known occupied get most. A cell's share counts in full only if
it holds most of the evidence (``dominant_share``) and the cone's arc at that range is at most a
cell wide (``unambiguous_arc``); any other share may lift a cell only up to ``ambiguous_ceiling``,
below the occupied threshold. Cells cleared around a wide arc prove nothing about the one left
standing, and the same ambiguous arc read over and over is not new evidence: so a cone straddling
a free corridor and reading its wall at the edge never fills the corridor, however long it stares,
while single rays and the cone close in mark obstacles after a few consistent readings. Hits within
the noise of known geometry (known obstacles, arena walls) are the known geometry's and leave the
sensed layer alone, so known walls are not narrowed by noisy copies of themselves.

Readings come in as ``RangeObservation``s; ``range_observations`` builds them from the head's
sensor layout (``sim.sensors``), a tracked pose and the readings by sensor name.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from domain.world.grid import Flat, Grid, unique_cells, unique_counts, unique_inverse
from domain.world.observation import RangeObservation, range_observations
from domain.world.sensed import clearing as kernel
from domain.world.sensed import marking as occupancy_marking
from domain.world.sensed.beams import arc_cells, likelihoods, swept_cells
from sim.robot import Array

if TYPE_CHECKING:
    from domain.world.settings import CostmapSettings

__all__ = ["RangeObservation", "SensedLayer", "range_observations"]


@dataclass
class _Updates:
    """One integration's cell updates, gathered before they are applied (clearing first)."""

    free: list[Flat]
    sure_cells: list[Flat]  # unambiguous hit shares
    sure_gain: list[Array]
    vague_cells: list[Flat]  # ambiguous hit shares (raise at most to the ceiling)
    vague_gain: list[Array]


class SensedLayer:
    """Log-odds occupancy from range readings; ``occupied`` is the thresholded view.

    ``compiled`` picks the numba kernels (``domain.occupancy_kernel`` and
    ``domain.occupancy_marking``, the default when numba is there) or the numpy path; both give
    the same layer, value for value.
    """

    def __init__(self, grid: Grid, settings: CostmapSettings, compiled: bool | None = None) -> None:
        self.grid = grid
        self.settings = settings
        self.log_odds = np.zeros(grid.shape)
        self.occupied = np.zeros(grid.shape, dtype=bool)
        self.compiled = kernel.AVAILABLE if compiled is None else compiled and kernel.AVAILABLE
        # the cells the last update lowered (cleared), flat: the only ones whose log-odds fell
        self.lowered: Flat = np.zeros(0, dtype=np.intp)
        # the cells whose log-odds the last update may have changed (flat, in parts)
        self.touched: list[Flat] = []
        self._scratch: tuple[Array, ...] | None = None
        # the grid as the kernels take it: (origin x, origin y, resolution), (nx, ny)
        self._geometry = np.array([grid.origin[0], grid.origin[1], grid.resolution])
        self._shape = np.array(grid.shape, dtype=np.int64)
        self._likelihoods = _likelihood_table(17)  # grown when a noisier sensor reads

    def integrate(
        self, observations: Iterable[RangeObservation], known_clearance: Array
    ) -> tuple[Flat, Flat]:
        """Apply readings; ``known_clearance`` is the static layer's clearance per cell.

        Returns the flat indices of cells that became occupied and of cells that stopped being so.
        """
        if self.compiled:
            # Only the readings' numbers, one row each, to the compiled bookkeeping.
            rows = [
                (*o.origin, o.angle, o.fov, o.max_range, o.distance, o.hit, o.noise_std)
                for o in observations
                if not math.isnan(o.distance)  # NaN: dropout
            ]
            return self._integrate_compiled(rows, known_clearance)
        valid = [obs for obs in observations if not math.isnan(obs.distance)]  # NaN: dropout
        return self._integrate_numpy(valid, known_clearance)

    def free(self, cells: Flat) -> Flat:
        """``cells`` (flat, distinct) are known free (the body lies over them): their log-odds go
        to the floor. Returns those that stopped being occupied."""
        if not cells.size:
            return cells
        occupied = self.occupied.reshape(-1)
        if self.compiled:
            out: Flat = kernel.free_cells(
                self.log_odds.reshape(-1), occupied, cells, self.settings.log_odds_min
            )
            return out
        ceased = cells[occupied[cells]]
        self.log_odds.reshape(-1)[cells] = self.settings.log_odds_min
        occupied[ceased] = False
        return ceased

    def _integrate_compiled(
        self, rows: Sequence[tuple[float | bool, ...]], known_clearance: Array
    ) -> tuple[Flat, Flat]:
        """``_integrate_numpy`` in compiled loops (the same numbers, a tenth of the time): the
        readings' layout, the clearing and the marking compiled; numpy's cos, sin and exp
        between them (numpy's SIMD versions may round differently from LLVM's)."""
        s, res = self.settings, self.grid.resolution
        step = s.sample_step * res
        if not rows:
            empty = np.zeros(0, dtype=np.intp)
            self.lowered = empty
            self.touched = []
            return empty, empty
        if self._scratch is None:
            n = self.grid.nx * self.grid.ny
            self._scratch = (np.full(n, -1, np.int64), np.zeros(n), np.zeros(n), np.zeros(n))
        mark, acc, sure_acc, vague_acc = self._scratch
        table = np.array(rows, dtype=float)
        while True:
            laid = kernel.layout(
                table,
                step,
                s.clear_sigmas,
                s.clear_margin,
                s.explained_sigmas,
                res,
                s.unambiguous_arc,
                *self._likelihoods,
            )
            if laid[-1] < self._likelihoods[2].size - 1:
                break
            self._likelihoods = _likelihood_table(laid[-1])  # a noisier sensor than so far
        sweep_dirs, arc_dirs, beams, swept, hits, hit_range, z_all, w_all, tolerance, narrow, _ = (
            laid
        )
        flat = self.log_odds.reshape(-1)
        arc, lik, bounds, cleared = kernel.sweep_and_clear(
            flat,
            self._geometry,
            self._shape,
            np.cos(sweep_dirs),
            np.sin(sweep_dirs),
            np.cos(arc_dirs),
            np.sin(arc_dirs),
            beams,
            swept,
            step,
            hits,
            hit_range,
            z_all,
            w_all,
            s.log_odds_free,
            s.log_odds_min,
            mark,
            acc,
        )
        self.lowered = cleared
        self.touched = [cleared, arc]  # every cell a hit could mark is an arc cell
        # The occupancy odds of each arc cell after clearing (numpy's exp, as the numpy path
        # computes it); cells within the noise of known geometry are explained by it.
        became, ceased = occupancy_marking.explain_share_and_mark(
            flat,
            self.occupied.reshape(-1),
            known_clearance.reshape(-1),
            arc,
            lik,
            bounds,
            tolerance,
            np.exp(-flat[arc]),
            narrow,
            cleared,
            s.log_odds_hit,
            s.dominant_share,
            s.log_odds_max,
            s.ambiguous_ceiling,
            s.occupied_threshold,
            sure_acc,
            vague_acc,
            mark,
        )
        return became, ceased

    def _integrate_numpy(
        self, valid: list[RangeObservation], known_clearance: Array
    ) -> tuple[Flat, Flat]:
        """The update in numpy: the reference the compiled kernels are held to."""
        s, res = self.settings, self.grid.resolution
        step = s.sample_step * res
        reach = [min(obs.distance, obs.max_range) for obs in valid]
        margins = [s.clear_sigmas * obs.noise_std + s.clear_margin for obs in valid]
        owner, cell = swept_cells(
            self.grid, [(o, d - m) for o, d, m in zip(valid, reach, margins, strict=True)], step
        )
        cells_total = self.grid.nx * self.grid.ny
        hits: list[tuple[RangeObservation, Flat, Array]] = []
        hit_keys = []
        which = [k for k, obs in enumerate(valid) if obs.hit]
        arcs = arc_cells(self.grid, [(valid[k], reach[k]) for k in which], step / 2)
        for k, (cells, likelihood) in zip(which, arcs, strict=True):
            hit_keys.append(k * cells_total + cells)  # a hit cell is not cleared by its beam
            if cells.size:
                hits.append((valid[k], cells, likelihood))
        if hit_keys:
            cleared = ~np.isin(owner * cells_total + cell, np.concatenate(hit_keys))
            cell = cell[cleared]
        updates = _Updates([cell], [], [], [], [])
        flat = self.log_odds.reshape(-1)
        touched = [self._apply_free(flat, updates.free)]
        self.lowered = touched[0]
        # Hit shares use the cleared state: evidence goes to arc cells the beams left standing.
        for obs, cells, likelihood in hits:
            self._share_hit(obs, cells, likelihood, known_clearance.reshape(-1), updates)
        touched.append(self._apply_hits(flat, updates))
        self.touched = touched
        return self._threshold(unique_cells(np.concatenate(touched)))

    def _share_hit(
        self,
        obs: RangeObservation,
        cells: Flat,
        likelihood: Array,
        known_clearance: Array,
        updates: _Updates,
    ) -> None:
        """Split one hit's evidence across its cells by range likelihood x occupancy probability.

        A cell is sure of its share only if it holds most of it and the arc is narrow; otherwise
        other cells along a wide arc could have caused the hit just as well (and cells cleared by
        other readings make whichever cell remains look likely, so that alone proves nothing).
        """
        s = self.settings
        tolerance = s.explained_sigmas * obs.noise_std + self.grid.resolution * math.sqrt(0.5)
        explained = known_clearance[cells] <= tolerance
        p = np.where(explained, 1.0, 1.0 / (1.0 + np.exp(-self.log_odds.reshape(-1)[cells])))
        share = likelihood * p / np.sum(likelihood * p)
        narrow = (
            obs.fov * min(obs.distance, obs.max_range) <= s.unambiguous_arc * self.grid.resolution
        )
        sure = ~explained & (share > s.dominant_share) & narrow
        vague = ~explained & ~sure
        updates.sure_cells.append(cells[sure])
        updates.sure_gain.append(s.log_odds_hit * share[sure])
        updates.vague_cells.append(cells[vague])
        updates.vague_gain.append(s.log_odds_hit * share[vague])

    def _apply_free(self, flat: Array, free: list[Flat]) -> Flat:
        if not free:
            return np.zeros(0, dtype=np.intp)
        cells, n = unique_counts(np.concatenate(free))
        s = self.settings
        flat[cells] = np.maximum(flat[cells] + n * s.log_odds_free, s.log_odds_min)
        return cells

    def _apply_hits(self, flat: Array, updates: _Updates) -> Flat:
        s = self.settings
        sure_cells, sure_gain = _summed(updates.sure_cells, updates.sure_gain)
        flat[sure_cells] = np.minimum(flat[sure_cells] + sure_gain, s.log_odds_max)
        vague_cells, vague_gain = _summed(updates.vague_cells, updates.vague_gain)
        now = flat[vague_cells]
        # Ambiguous evidence may lift a cell up to the ceiling, never lower it, never past it.
        flat[vague_cells] = np.maximum(now, np.minimum(now + vague_gain, s.ambiguous_ceiling))
        return np.concatenate([sure_cells, vague_cells])

    def _threshold(self, touched: Flat) -> tuple[Flat, Flat]:
        occupied = self.occupied.reshape(-1)
        before = occupied[touched]
        after = self.log_odds.reshape(-1)[touched] > self.settings.occupied_threshold
        occupied[touched] = after
        return touched[after & ~before], touched[before & ~after]


def _likelihood_table(largest: int) -> tuple[Array, Array, NDArray[np.int64]]:
    """``beams.likelihoods(n)`` for n = 1..``largest`` one after the other (z values, weights)
    and where each n starts (``[largest + 2]``), for the compiled layout."""
    parts = [likelihoods(n) for n in range(1, largest + 1)]
    first = np.cumsum([0, 0, *(z.size for z, _ in parts)]).astype(np.int64)
    z = np.concatenate([z for z, _ in parts])
    w = np.concatenate([w for _, w in parts])
    return z, w, first


def _summed(cells: list[Flat], gains: list[Array]) -> tuple[Flat, Array]:
    """Per-cell sums of gains given as parallel lists of (cells, gains)."""
    if not cells:
        return np.zeros(0, dtype=np.intp), np.zeros(0)
    all_cells = np.concatenate(cells)
    unique, inverse = unique_inverse(all_cells)
    sums = np.bincount(inverse, weights=np.concatenate(gains), minlength=unique.size)
    return unique, np.asarray(sums, dtype=np.float64)

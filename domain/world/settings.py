"""Every behavioural parameter of the costmap, with its unit and reason, in one typed object.

Log-odds are natural logarithms of the odds. The sensed layer's parameters shape how range
readings become occupancy; the evidence and observation parameters shape the soft layer the
planner pays for (never lethal: see ``domain.world.model``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class CostmapSettings:
    """The world model's layers: resolution, the sensed layer's sensor model, contact evidence
    and the cost of never-observed space."""

    resolution: float = 0.05
    """metres per cell (the lattice uses the same cells)"""

    # -- sensed layer: range readings into log-odds occupancy --------------------------------
    log_odds_free: float = -0.4
    """per reading, for each cell its beam cleared"""
    log_odds_hit: float = 0.85
    """one reading's hit evidence, shared across its arc cells"""
    log_odds_min: float = -2.0
    """clamps keep the layer responsive to change"""
    log_odds_max: float = 3.5
    occupied_threshold: float = 1.5
    """two consistent single-ray hits (2 x 0.85) cross it: one noisy echo never does"""
    ambiguous_ceiling: float = 1.0
    """an ambiguous arc share raises a cell at most to this (below the threshold)"""
    dominant_share: float = 0.5
    """an arc cell holding more of a hit's evidence than this is unambiguous ..."""
    unambiguous_arc: float = 1.0
    """... if the cone's arc at the hit is at most this many cells wide"""
    clear_sigmas: float = 2.0
    """clearing stops this many noise σ short of the measured range ..."""
    clear_margin: float = 0.025
    """... plus this (m)"""
    explained_sigmas: float = 2.0
    """a hit within this many σ + half a cell diagonal of known geometry is the known
    geometry's and leaves the sensed layer alone"""
    sample_step: float = 0.5
    """beam sample spacing, in cells"""
    max_clearance: float = 2.0
    """clearance saturates here (m); exact below it"""

    # -- contact evidence: a bumper's report spread along the touched side -------------------
    contact_probability: float = 0.9
    """the evidence one contact carries: how likely what was touched is there still (it is
    shared by the cells along the touched side: a side bumper spans its whole unit)"""
    contact_extent: float = 0.05
    """metres the evidence reaches past each end of the touched side (the contact may lie at
    the unit's rounded end)"""
    contact_standoff: float = 0.02
    """metres beyond the touched surface where the evidence lies (the robot stops just short)"""
    contact_half_life: float = 300.0
    """model seconds in which contact evidence fades to half (beams that see a cell free clear
    it at once)"""

    # -- never-observed space ----------------------------------------------------------------
    unobserved_density: float = 1.5
    """expected obstacles per square metre of never-observed space (cells no beam crossed and
    the body never covered): what sweeping such space blind risks (a field of 0.15 m posts
    0.5 m apart holds about 4 per m²)"""
    continuation_probability: float = 0.5
    """probability that a never-observed cell next to a sensed one is occupied too: the head
    sees part of an obstacle, and obstacles are extended (a wall seen as a dashed line has no
    gaps there, most likely) ..."""
    continuation_decay: float = 0.1
    """... falling by e every this many metres from the sensed cell ..."""
    continuation_reach: float = 0.3
    """... and none beyond this (m)"""

    def __post_init__(self) -> None:
        for f in fields(self):
            if not math.isfinite(getattr(self, f.name)):
                raise ValueError(f"costmap settings: {f.name} must be finite")
        positive = ("resolution", "log_odds_hit", "sample_step", "max_clearance")
        if any(getattr(self, name) <= 0 for name in positive):
            raise ValueError(f"costmap settings: {', '.join(positive)} must be positive")
        if not self.log_odds_free < 0:
            raise ValueError("costmap settings: log_odds_free must be negative")
        if not self.log_odds_min < 0 < self.ambiguous_ceiling < self.occupied_threshold:
            raise ValueError(
                "costmap settings: need log_odds_min < 0 < ambiguous_ceiling < occupied_threshold"
            )
        if not self.occupied_threshold < self.log_odds_max:
            raise ValueError("costmap settings: need occupied_threshold < log_odds_max")
        if not 0 < self.dominant_share < 1:
            raise ValueError("costmap settings: dominant_share must lie in (0, 1)")
        if not 0 <= self.contact_probability < 1:
            raise ValueError("costmap settings: contact_probability must lie in [0, 1)")
        if not 0 <= self.continuation_probability < 1:
            raise ValueError("costmap settings: continuation_probability must lie in [0, 1)")
        if not (self.continuation_decay > 0 and self.continuation_reach >= 0):
            raise ValueError("costmap settings: continuation_decay > 0, continuation_reach >= 0")
        margins = (self.clear_sigmas, self.clear_margin, self.explained_sigmas)
        lengths = (self.contact_extent, self.contact_standoff, self.unobserved_density)
        if min(*margins, *lengths, self.unambiguous_arc) < 0:
            raise ValueError(
                "costmap settings: margins, contact lengths, unambiguous_arc and "
                "unobserved_density must be >= 0"
            )
        if not self.contact_half_life > 0:
            raise ValueError("costmap settings: contact_half_life must be positive")
        if self.sample_step > 1:
            raise ValueError("costmap settings: sample_step above one cell would skip cells")

    def continuation_log_free(self, distance: NDArray[np.float64]) -> NDArray[np.float64]:
        """log P(free) of never-observed cells ``distance`` metres (between centres, less half a
        cell) from the nearest sensed cell (0 beyond ``continuation_reach``: priced only where
        it is not, a few cells round each sensed one rather than the whole grid)."""
        out: NDArray[np.float64] = np.zeros(np.shape(distance))
        near = distance <= self.continuation_reach
        q = self.continuation_probability * np.exp(
            -np.maximum(distance[near], 0.0) / self.continuation_decay
        )
        out[near] = np.log1p(-q)
        return out

    @property
    def unobserved_log_free(self) -> float:
        """log P(a never-observed cell is free): a Poisson field of ``unobserved_density``
        obstacles per m² leaves a cell free with probability exp(-density x cell area)."""
        return -self.unobserved_density * self.resolution**2

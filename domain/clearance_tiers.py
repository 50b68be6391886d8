"""What navigation plans keep clear of, in tiers tried in turn: the sensed world model's
obstacles inflated by how little is known of them, suspected surfaces (where a touched one
probably goes on) avoided, then passed closely near the goals, then planned through, and last
contacts and what the head saw passed only just."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np
from numpy.typing import NDArray

from domain.grid import cells_round
from domain.grid_clearance import ClearanceGrids, GridClearance
from domain.interpolate import bilinear
from sim.robot import Array

if TYPE_CHECKING:
    from domain.worldmodel import WorldModel

SENSED_INFLATION = 0.05  # metres plans keep beyond what the head saw of a hidden obstacle
CONTACT_INFLATION = 0.1  # ... and beyond where a bumper touched one (it felt a single point)
CONTACT_BARE = 0.02  # ... when no plan exists otherwise: a new touch adds a new contact point
SENSED_BARE = 0.01  # ... and from what the head saw (squeezing past debris in a pipe)
GOAL_UNSUSPECTED = (
    1.0  # metres round a goal where contacts and suspected surfaces are passed closely
)

Suspected = Literal["all", "off-goals", "none"]


@dataclass(frozen=True)
class Tier:
    """One way of keeping clear: suspected surfaces ``all`` avoided, avoided ``off-goals`` (in
    the world model's cells whose centre lies within ``GOAL_UNSUSPECTED`` of a goal, they and
    contacts kept only ``CONTACT_BARE`` clear; bilinear across the circle's edge), or ``none``;
    contacts grown by ``grow`` metres, sensed cells by ``sensed``."""

    suspected: Suspected
    grow: float = CONTACT_INFLATION
    sensed: float = SENSED_INFLATION


def tiers(any_suspected: bool) -> list[Tier]:
    """The tiers in the order a planner tries them."""
    out = [Tier("none"), Tier("none", CONTACT_BARE, SENSED_BARE)]
    return [Tier("all"), Tier("off-goals"), *out] if any_suspected else out


def tier_clearance(
    world: WorldModel, tier: Tier, goals: Sequence[tuple[float, float]] = ()
) -> GridClearance:
    """The clearance (m) at world points ``[..., 2]`` that plans of this tier keep, bilinear
    over one grid of the world model's, with its compiled form (``GridClearance.grids``)."""
    avoid = tier.suspected != "none"
    if tier.suspected == "off-goals" and goals:
        merged: list[tuple[int, Array]] = []  # (model version, grid): made once per version

        def values() -> Array:
            # One grid, so that the compiled search reads a single grid per point: the
            # cells round a goal from the closely passed grid, the rest from the avoiding one.
            if not merged or merged[0][0] != world.version:
                far = world.inflated_grid(tier.sensed, tier.grow, suspected=True)
                near = world.inflated_grid(tier.sensed, CONTACT_BARE, suspected=True)
                merged[:] = [(world.version, np.where(_close_to(world, goals), near, far))]
            return merged[0][1]
    else:

        def values() -> Array:
            return world.inflated_grid(tier.sensed, tier.grow, suspected=avoid)

    def clearance(pts: Array) -> Array:
        return bilinear(values(), world.grid, np.asarray(pts, dtype=float), world.bounds)

    def grids() -> ClearanceGrids:
        return ClearanceGrids.of(values(), world.grid, world.bounds)

    return GridClearance(clearance, grids)


def _close_to(world: WorldModel, goals: Sequence[tuple[float, float]]) -> NDArray[np.bool_]:
    """The world model's cells whose centre lies within ``GOAL_UNSUSPECTED`` of a goal."""
    grid = world.grid
    close = np.zeros((grid.nx, grid.ny), dtype=bool)
    for gx, gy in goals:  # the box round each goal only, not every cell times every goal
        i, j, distance = cells_round(grid.xs, grid.ys, (gx, gy), GOAL_UNSUSPECTED)
        inside = distance < GOAL_UNSUSPECTED
        close[i[inside], j[inside]] = True
    return close

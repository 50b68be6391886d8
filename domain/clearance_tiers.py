"""What navigation plans keep clear of, in tiers tried in turn: the sensed world model's
obstacles inflated by how little is known of them, suspected surfaces (where a touched one
probably goes on) avoided, then passed closely near the goals, then planned through, and last
contacts and what the head saw passed only just."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from domain.grid_clearance import ClearanceGrids, GridClearance
from sim.robot import Array

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
    """One way of keeping clear: suspected surfaces ``all`` avoided, avoided ``off-goals``
    (within ``GOAL_UNSUSPECTED`` of a goal, they and contacts kept only ``CONTACT_BARE`` clear),
    or ``none``; contacts grown by ``grow`` metres, sensed cells by ``sensed``."""

    suspected: Suspected
    grow: float = CONTACT_INFLATION
    sensed: float = SENSED_INFLATION


def tiers(any_suspected: bool) -> list[Tier]:
    """The tiers in the order a planner tries them."""
    out = [Tier("none"), Tier("none", CONTACT_BARE, SENSED_BARE)]
    return [Tier("all"), Tier("off-goals"), *out] if any_suspected else out


def tier_clearance(
    world: Any, tier: Tier, goals: Sequence[tuple[float, float]] = ()
) -> Callable[[Array], Array]:
    """The clearance (m) at world points ``[..., 2]`` that plans of this tier keep (with its
    compiled form, ``GridClearance.grids``, where the world model's grids can be read)."""
    if tier.suspected != "off-goals" or not goals:
        avoid = tier.suspected != "none"

        def clearance(pts: Array) -> Array:
            out: Array = world.inflated_clearance_at(pts, tier.sensed, tier.grow, suspected=avoid)
            return out

        def grids() -> ClearanceGrids:
            values = world.inflated_grid(tier.sensed, tier.grow, suspected=avoid)
            return ClearanceGrids.of(values, world.grid, world.bounds)

        return GridClearance(clearance, grids) if _readable(world) else clearance
    centres = np.asarray(goals, dtype=float)

    def off_goals(pts: Array) -> Array:
        pts = np.asarray(pts, dtype=float)
        out: Array = np.array(
            world.inflated_clearance_at(pts, tier.sensed, tier.grow, suspected=True),
            dtype=float,
        )
        close = np.linalg.norm(pts[..., None, :] - centres, axis=-1).min(axis=-1) < GOAL_UNSUSPECTED
        if np.any(close):  # the second lookup only where it decides
            out[close] = world.inflated_clearance_at(
                pts[close], tier.sensed, CONTACT_BARE, suspected=True
            )
        return out

    def off_goals_grids() -> ClearanceGrids:
        values = world.inflated_grid(tier.sensed, tier.grow, suspected=True)
        near = world.inflated_grid(tier.sensed, CONTACT_BARE, suspected=True)
        return ClearanceGrids.of(values, world.grid, world.bounds, near, centres, GOAL_UNSUSPECTED)

    return GridClearance(off_goals, off_goals_grids) if _readable(world) else off_goals


def _readable(world: Any) -> bool:
    """Whether the world model hands out its inflated grids (a ``WorldModel``; anything else
    keeps the plain callable and pyperplan's search)."""
    return callable(getattr(world, "inflated_grid", None)) and hasattr(world, "grid")

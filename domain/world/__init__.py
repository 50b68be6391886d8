"""The costmap: the robot's world model in layers (static, sensed, observed, contact evidence)
and the two views every planner reads, the lethal clearance and the soft risk.

This is the package's front door: the navigation planner, the reactive strategy and the
executor import from here.
"""

from domain.world.contact import SIDES, touched_side
from domain.world.grid import Grid
from domain.world.interpolate import bilinear
from domain.world.model import WorldModel
from domain.world.observation import RangeObservation, range_observations, trusted_observation
from domain.world.settings import CostmapSettings

__all__ = [
    "SIDES",
    "CostmapSettings",
    "Grid",
    "RangeObservation",
    "WorldModel",
    "bilinear",
    "range_observations",
    "touched_side",
    "trusted_observation",
]

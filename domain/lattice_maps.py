"""The distance maps a lattice planner keeps per world version: the clearance at the cell
centres, the usual footprint-aware map per goal and the roomy one (domain/lattice_distances.py).

A replan asks for the same maps several times (the reachability test, each clearance tier's
search, the enclosed-goal answer); each is made once per world version, goal and start.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from domain.goal_order import LegGoal
from domain.lattice import LatticeGrid, MotionTable, body_key
from domain.lattice_distances import centroid_need, distance_map, roomy_map
from domain.lattice_task import Clearance
from sim.robot import Array

MAPS_KEPT = 64  # distance maps kept (then all are dropped: a new world version needs new ones)


class PlannerMaps:
    """Distance maps and cell-centre clearances, made on first use per world version."""

    def __init__(self, grid: LatticeGrid) -> None:
        self.grid = grid
        self._maps: dict[tuple[Any, ...], Array] = {}
        self._centres: tuple[Any, Array] | None = None

    @property
    def at_centres(self) -> Array | None:
        """The clearance at every cell centre for the last world version asked for."""
        return self._centres[1] if self._centres is not None else None

    def centre_clearance(self, clearance: Clearance, version: Any) -> Array:
        """The clearance at every cell centre for a world version (computed once per version:
        the distance maps, the heuristic and the motion cache all read it)."""
        if self._centres is None or self._centres[0] != version:
            self._centres = (version, clearance(self.grid.centres))
        return self._centres[1]

    def distances(
        self,
        table: MotionTable,
        clearance: Clearance,
        version: Any,
        goal: LegGoal,
        start: tuple[float, float] | None = None,
    ) -> Array:
        """``distance_map`` of ``table``'s body to ``goal`` (cells near ``start`` passable)."""
        key = (version, body_key(table), goal.x, goal.y, start)
        if key not in self._maps:
            self._keep(
                key,
                distance_map(
                    self.grid,
                    self.centre_clearance(clearance, version),
                    (goal.x, goal.y),
                    centroid_need(table),
                    _goal_free(table, goal),
                    start,
                ),
            )
        return self._maps[key]

    def roomy(
        self,
        table: MotionTable,
        clearance: Clearance,
        version: Any,
        goal: LegGoal,
        start: tuple[float, float],
        origin: tuple[float, float],
        usual: Array,
        margin: float,
    ) -> Array:
        """``roomy_map`` of a leg from ``start`` (``usual``: its distance map, made with the
        cells near ``origin``, the plan's start, passable: part of what the map is kept by)."""
        key = ("roomy", version, body_key(table), goal.x, goal.y, start, origin, margin)
        if key not in self._maps:
            at = self.centre_clearance(clearance, version)
            free = _goal_free(table, goal)
            self._keep(
                key, roomy_map(self.grid, at, (goal.x, goal.y), table, margin, free, start, usual)
            )
        return self._maps[key]

    def enclosed(
        self,
        table: MotionTable,
        goal: LegGoal,
        cell: tuple[int, int],
        static: tuple[Clearance, Any] | None,
    ) -> str:
        """Why ``goal`` is cut off from the start's ``cell``: known obstacles enclose it (the
        map of ``static``, the known obstacles' clearance and version, has no way either) or
        sensed ones do."""
        by = "known/sensed obstacles"
        if static is not None:
            known = self.distances(table, static[0], ("static", static[1]), goal)
            by = "known obstacles" if not math.isfinite(known[cell]) else "sensed obstacles"
        return f"unreachable: goal {goal.index} at ({goal.x:g}, {goal.y:g}) enclosed by {by}"

    def _keep(self, key: tuple[Any, ...], made: Array) -> None:
        if len(self._maps) >= MAPS_KEPT:
            self._maps.clear()
        self._maps[key] = made


def _goal_free(table: MotionTable, goal: LegGoal) -> float:
    """How far from the goal the centroid may lie with the head on it: passable cells."""
    return float(np.linalg.norm(table.offset)) + goal.tolerance

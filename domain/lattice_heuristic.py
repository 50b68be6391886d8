"""The planner's heuristic on the lattice: the footprint-aware distance to the goal with two
orientation terms, and the most promising node a search met (a partial plan when time runs out).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
from pyperplan.heuristics.heuristic_base import Heuristic

from domain.lattice_states import LatticeState
from sim.robot import Array

if TYPE_CHECKING:
    from domain.lattice_task import LatticeTask


class LatticeHeuristic(Heuristic):  # type: ignore[misc]
    """Footprint-aware 2-D distance to the goal in moves of ``step`` metres (0 once visited),
    plus two orientation terms that break the ties a 2-D distance leaves: a small one for
    leading with the head along the way (the head carries the sensors), and, where the way is
    narrow, one for the body axis (either way along it) against the way's direction, so a
    greedy search lines the body up with a corridor instead of trying every heading at its
    mouth. It also remembers the most promising node it saw (a partial plan when time runs
    out)."""

    ALIGN_WEIGHT = 2.0
    HEAD_WEIGHT = 0.5
    NARROW = 0.5  # metres of clearance below which a cell counts as narrow

    def __init__(self, task: LatticeTask, distances: Array, step: float) -> None:
        self.task, self.distances, self.step = task, distances, step
        self.reach = float(np.linalg.norm(task.table.offset))
        finite = np.isfinite(distances)
        filled = np.where(finite, distances, float(np.max(distances[finite], initial=0.0)) + 1.0)
        gx, gy = np.gradient(filled)
        way = np.arctan2(-gy, -gx)  # direction of steepest descent: along the way
        grid = task.grid
        at_centres = task.at_centres
        if at_centres is None:
            at_centres = task.clearance(grid.centres)
        narrow = at_centres < self.NARROW
        self.turn_step = grid.settings.step
        base = np.maximum(0.0, distances - self.reach) / step + 1.0
        # Read per cell the first time a search meets it (a search meets few of the cells:
        # whole-grid lists cost more than the search on a large arena).
        self.base = np.where(finite, base, math.inf).ravel()
        self.narrow = narrow.ravel()
        self.way = way.ravel()
        self.cells: dict[int, tuple[float, float, bool]] = {}
        self.plane = grid.nx * grid.ny
        self.best: tuple[float, Any] | None = None

    def __call__(self, node: Any) -> float:
        state = node.state
        if type(state) is LatticeState:  # the search's own states: no scan for the facts
            if state.visited:
                return 0.0
            number: int | None = state.number
        else:
            if self.task.goal_fact in state:
                return 0.0
            number = self.task.at(state)
            if number is None:
                return math.inf
        k, cell = divmod(number, self.plane)  # type: ignore[operator]  # encode(): (k * nx + i) * ny + j
        at = self.cells.get(cell)
        if at is None:
            at = (float(self.base[cell]), float(self.way[cell]), bool(self.narrow[cell]))
            self.cells[cell] = at
        h, way, narrow = at
        psi = k * self.turn_step
        # e(ψ) points to the tail: the head leads along ψ + π.
        h += self.HEAD_WEIGHT * abs(math.remainder(psi + math.pi - way, 2 * math.pi)) / math.pi
        if narrow:
            h += self.ALIGN_WEIGHT * abs(math.remainder(psi - way, math.pi)) / (math.pi / 2)
        if self.best is None or h < self.best[0]:
            self.best = (h, node)
        return h

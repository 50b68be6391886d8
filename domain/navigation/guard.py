"""The plan guard's check: the next moves' swept points against the lethal layer, in one lookup.

Whenever the lethal layer changes, the navigation strategy re-checks the swept footprints of
the next ``lookahead`` plan steps (soft costs never break a plan: only what is lethal does). Their points and the clearance each needs depend only on the
plan, its motion table and where in the plan the robot is, so ``Lookahead`` gathers them once
for those and each check is one clearance lookup over all of them; the first move (in plan
order) with a point short of its need is the blocked one, as checking the moves one by one
finds it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from domain.navigation.lattice.grid import LatticeGrid
from domain.navigation.lattice.motions import MotionTable
from domain.navigation.plan import Plan, PlanAction
from sim.robot import Array

Move = tuple[PlanAction, tuple[float, float], int]  # the move, its start centre, its end


class Lookahead:
    """The swept points of a plan's next moves, gathered once per plan, table and first step."""

    def __init__(self, lookahead: int) -> None:
        self.lookahead = lookahead
        self._key: tuple[Any, ...] = (None, None, (-1, 0))
        self._moves: list[Move] = []
        self._points, self._needs = np.zeros((0, 2)), np.zeros(0)

    def first_blocked(
        self,
        plan: Plan,
        table: MotionTable,
        first: int,
        grid: LatticeGrid,
        margin: float,
        clearance: Any,
    ) -> tuple[PlanAction, tuple[float, float]] | None:
        """The first move of the plan steps from ``first`` whose swept points ``clearance``
        (a function of world points ``[N, 2]``) puts short of the clearance they need plus
        ``margin``, with its start centre; ``None`` if none is."""
        # the same objects (not equal ones), the same list of actions, as long, from the same step
        key, steps = self._key, (first, len(plan.actions))
        if key[0] is not plan.actions or key[1] is not table or key[2] != steps:
            self._key = (plan.actions, table, steps)
            self._moves, self._points, self._needs = self._gather(plan, table, first, grid, margin)
        if not self._moves:
            return None
        blocked = np.flatnonzero(~(clearance(self._points) >= self._needs))
        if not blocked.size:
            return None
        ends = [end for _, _, end in self._moves]
        action, centre, _ = self._moves[int(np.searchsorted(ends, blocked[0], "right"))]
        return action, centre

    def _gather(
        self, plan: Plan, table: MotionTable, first: int, grid: LatticeGrid, margin: float
    ) -> tuple[list[Move], Array, Array]:
        """The moves the guard checks (each with its start centre and where its points end),
        their swept points and the clearance each needs plus ``margin``."""
        moves, centres, points, needs = [], [], [], []
        end = 0
        r, x0, y0 = grid.settings.resolution, grid.bounds.xmin, grid.bounds.ymin
        steps = plan.actions[first : first + self.lookahead]
        for n, action in enumerate(steps, start=first):
            if action.name != "move" or action.source is None or action.motion is None:
                continue
            if n == 0:
                continue  # out of the start: planned with the start's own (relaxed) margin
            i, j, k = action.source
            centre = (x0 + (i + 0.5) * r, y0 + (j + 0.5) * r)  # as grid.centre(i, j)
            seg = table.segments[k]
            m = action.motion
            lo = int(seg[m])
            hi = int(seg[m + 1]) if m + 1 < len(seg) else len(table.points[k])
            end += hi - lo
            moves.append((action, centre, end))
            centres.append(centre)
            points.append(table.points[k][lo:hi])
            needs.append(table.needs[k][lo:hi])
        if not moves:
            return [], np.zeros((0, 2)), np.zeros(0)
        sizes = [p.shape[0] for p in points]
        # each move's points offset by its centre, element by element as centre + points
        swept = np.concatenate(points) + np.repeat(np.array(centres), sizes, axis=0)
        return moves, swept, np.concatenate(needs) + margin

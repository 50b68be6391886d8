"""The plan guard's check: the next moves' swept points against the lethal layer, in one lookup.

Whenever the lethal layer changes, the navigation strategy re-checks the swept footprints of
the next ``lookahead`` plan steps (soft costs never break a plan: only what is lethal does).
Their points and the clearance each needs depend only on the plan and its motion table, so
``Lookahead`` gathers them once per plan, every step's in plan order, and a check from any
step is one clearance lookup over the slice of its next steps; the first move (in plan order)
with a point short of its need is the blocked one, as checking the moves one by one finds it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from domain.navigation.lattice.grid import LatticeGrid
from domain.navigation.lattice.motions import MotionTable
from domain.navigation.plan import Plan, PlanAction

Move = tuple[PlanAction, tuple[float, float]]  # a checked move and its start centre


class Lookahead:
    """The swept points of every step of a plan, gathered once per plan and table."""

    def __init__(self, lookahead: int) -> None:
        self.lookahead = lookahead
        self._key: tuple[Any, ...] = (None, None, 0, 0.0)
        self._moves: list[Move | None] = []  # per plan step (None: nothing to check)
        self._offsets = np.zeros(1, dtype=np.intp)  # per step, where its points start
        self._points, self._needs = np.zeros((0, 2)), np.zeros(0)
        # the lethal layer's version of the last check and the points it found clear
        self._clear: tuple[Any, int, int] = (None, 0, 0)

    def first_blocked(
        self,
        plan: Plan,
        table: MotionTable,
        first: int,
        grid: LatticeGrid,
        margin: float,
        clearance: Any,
        version: Any = None,
    ) -> tuple[PlanAction, tuple[float, float]] | None:
        """The first move of the plan steps from ``first`` whose swept points ``clearance``
        (a function of world points ``[N, 2]``) puts short of the clearance they need plus
        ``margin``, with its start centre; ``None`` if none is. ``version`` names what
        ``clearance`` reads (the lethal layer's version): while it stays the same, the points
        the last check found clear are not looked up again (``None``: every point is)."""
        # the same objects (not equal ones): the same list of actions, as long
        key = self._key
        if (
            key[0] is not plan.actions
            or key[1] is not table
            or key[2:] != (len(plan.actions), margin)
        ):
            self._key = (plan.actions, table, len(plan.actions), margin)
            self._gather(plan, table, grid, margin)
            self._clear = (None, 0, 0)
        steps = len(self._moves)
        first = min(max(first, 0), steps)
        lo = int(self._offsets[first])
        hi = int(self._offsets[min(first + self.lookahead, steps)])
        seen, clear_lo, clear_hi = self._clear
        start = lo
        if version is not None and seen == version and clear_lo <= lo <= clear_hi:
            start = clear_hi  # the points before it were clear at this version
        self._clear = (version, lo, max(start, lo))
        if start >= hi:
            return None
        blocked = np.flatnonzero(~(clearance(self._points[start:hi]) >= self._needs[start:hi]))
        if not blocked.size:
            self._clear = (version, lo, hi)
            return None
        step = int(np.searchsorted(self._offsets, start + int(blocked[0]), "right")) - 1
        move = self._moves[step]
        assert move is not None  # (a step without points holds no blocked point)
        return move

    def _gather(self, plan: Plan, table: MotionTable, grid: LatticeGrid, margin: float) -> None:
        """Every step's move (with its start centre), swept points and the clearance each
        needs plus ``margin``; the first step and anything but a move have none."""
        moves: list[Move | None] = []
        centres, points, needs, sizes = [], [], [], [0]
        r, x0, y0 = grid.settings.resolution, grid.bounds.xmin, grid.bounds.ymin
        for n, action in enumerate(plan.actions):
            # the first step leaves the start: planned with the start's own (relaxed) margin
            if n == 0 or action.name != "move" or action.source is None or action.motion is None:
                moves.append(None)
                sizes.append(0)
                continue
            i, j, k = action.source
            centre = (x0 + (i + 0.5) * r, y0 + (j + 0.5) * r)  # as grid.centre(i, j)
            seg = table.segments[k]
            m = action.motion
            lo = int(seg[m])
            hi = int(seg[m + 1]) if m + 1 < len(seg) else len(table.points[k])
            moves.append((action, centre))
            centres.append(centre)
            points.append(table.points[k][lo:hi])
            needs.append(table.needs[k][lo:hi])
            sizes.append(hi - lo)
        self._moves = moves
        self._offsets = np.cumsum(sizes, dtype=np.intp)
        if not points:
            self._points, self._needs = np.zeros((0, 2)), np.zeros(0)
            return
        # each move's points offset by its centre, element by element as centre + points
        self._points = np.concatenate(points) + np.repeat(
            np.array(centres), [p.shape[0] for p in points], axis=0
        )
        self._needs = np.concatenate(needs) + margin

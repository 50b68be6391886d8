"""Whether any body motion can bring the head to a goal: connectivity of the lattice's free
configuration space (cell, orientation), a cheap test that is sound for "unreachable".

The 2-D distance map treats the body as its centroid, so it misses places the body fits into
but cannot turn in (a dead-end lane entered tail first). Searching the lattice to exhaustion
would decide them but takes long; labelling the free configurations instead is one array
operation per body sample point and one ``scipy.ndimage.label``. The test relaxes the
lattice: a configuration is free when the resting body keeps its clearance (less the half cell
diagonal a point may sit off the cell centre it is rounded to), and neighbouring free
configurations (8 cells around at one orientation, or one orientation step in place) connect.
Every lattice motion joins configurations this relaxation also joins, so a goal outside the
start's component cannot be reached by any plan; the converse need not hold.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from domain import reach_kernel
from domain.lattice import Key, LatticeGrid, MotionTable
from domain.reach_components import Components, carried_over, exact_components
from sim.robot import Array


class BodyRows(NamedTuple):
    """The resting body per orientation bin, as the reachability kernels read it."""

    shifts: NDArray[np.int64]  # [K, U, 2] distinct cell offsets of the body's points
    thresholds: Array  # [K, U] the clearance each needs there
    counts: NDArray[np.int64]  # [K] rows used per bin (-1: the body reaches past any grid)


_ROWS: dict[tuple[int, float, int, float], tuple[MotionTable, BodyRows]] = {}
ROWS_KEPT = 16  # tables whose rows are kept (they depend on the table, never on the world)


def body_rows(grid: LatticeGrid, table: MotionTable, margin: float) -> BodyRows:
    """Per bin, the resting body's distinct cell offsets (``[K, U, 2]``) and the clearance each
    needs there (``[K, U]``: the largest need rounded into it + ``margin`` - half a cell
    diagonal), and how many rows each bin uses (-1: the body reaches past any grid). Made once
    per table and lattice and shared: not to be written."""
    key = (id(table), grid.settings.resolution, grid.settings.orientations, margin)
    got = _ROWS.get(key)
    if got is not None and got[0] is table:
        return got[1]
    rows = _body_rows(grid, table, margin)
    if len(_ROWS) >= ROWS_KEPT:
        _ROWS.clear()
    _ROWS[key] = (table, rows)
    return rows


def _body_rows(grid: LatticeGrid, table: MotionTable, margin: float) -> BodyRows:
    r = grid.settings.resolution
    pad = max(1, math.ceil(table.geometry.body_length / r) + 2)
    slack = r * math.sqrt(0.5)
    K = grid.settings.orientations
    rows = []
    for k in range(K):
        shifts = np.rint(table.body_points[k] / r).astype(np.int64)
        # One comparison per distinct cell shift, against the largest need rounded into it.
        unique, inverse = np.unique(shifts, axis=0, return_inverse=True)
        needs = np.full(len(unique), -np.inf)
        np.maximum.at(needs, inverse.ravel(), table.body_needs[k])
        rows.append((unique, needs + margin - slack))
    width = max(len(u) for u, _ in rows)
    shifts_out = np.zeros((K, width, 2), dtype=np.int64)
    thresholds = np.full((K, width), -np.inf)
    counts = np.empty(K, dtype=np.int64)
    for k, (unique, need) in enumerate(rows):
        shifts_out[k, : len(unique)], thresholds[k, : len(unique)] = unique, need
        counts[k] = -1 if np.any(np.abs(unique) >= pad) else len(unique)
    return BodyRows(shifts_out, thresholds, counts)


def free_configurations(
    grid: LatticeGrid,
    table: MotionTable,
    at_centres: Array,
    margin: float,
    rows: BodyRows | None = None,
    previous: tuple[Array, NDArray[np.bool_]] | None = None,
) -> NDArray[np.bool_]:
    """``[K, nx, ny]``: where the resting body may lie (relaxed by half a cell diagonal), from
    the clearance at ``grid.centres`` (``rows``: ``body_rows`` of the same, if made already).
    ``previous``: the clearance at the centres and the answer for an earlier world model of
    the same lattice, body and margin; only the cells within the body's reach of a cell whose
    clearance changed are compared again (a replan after sensing changes little)."""
    nx, ny = grid.nx, grid.ny
    clear = at_centres.reshape(nx, ny)
    pad = body_pad(grid, table)
    rows = rows if rows is not None else body_rows(grid, table, margin)
    shifts, thresholds, counts = rows
    box = (slice(0, nx), slice(0, ny))
    if previous is not None and previous[1].shape == (grid.settings.orientations, nx, ny):
        free = previous[1].copy()
        changed = changed_box(clear, previous[0].reshape(nx, ny), pad, float(thresholds.max()))
        if changed is None:
            return free
        box = changed
        free[:, box[0], box[1]] = True
    else:
        free = np.ones((grid.settings.orientations, nx, ny), dtype=bool)
    # Padded with -inf: a body point off the grid is outside the arena.
    padded = np.full((nx + 2 * pad, ny + 2 * pad), -np.inf)
    padded[pad : pad + nx, pad : pad + ny] = clear
    (i0, i1), (j0, j1) = (box[0].start, box[0].stop), (box[1].start, box[1].stop)
    for k, n in enumerate(counts.tolist()):
        part = free[k, i0:i1, j0:j1]
        if n < 0:
            part[...] = False
            continue
        for (di, dj), need in zip(shifts[k, :n], thresholds[k, :n], strict=True):
            part &= padded[pad + di + i0 : pad + di + i1, pad + dj + j0 : pad + dj + j1] >= need
    return free


def body_pad(grid: LatticeGrid, table: MotionTable) -> int:
    """Cells round a configuration's own that its resting body's points may read."""
    return max(1, math.ceil(table.geometry.body_length / grid.settings.resolution) + 2)


def changed_box(
    clear: Array, earlier: Array, pad: int, cap: float = math.inf
) -> tuple[slice, slice] | None:
    """The box of cells whose configurations may differ between two clearances at the cell
    centres (``[nx, ny]``): the changed cells' bounding box grown by ``pad`` (``None``: no
    cell changed). Clearance above ``cap`` (the most any body point needs) decides nothing:
    a change above it is no change."""
    changed = np.minimum(clear, cap) != np.minimum(earlier, cap)
    rows, cols = np.flatnonzero(changed.any(axis=1)), np.flatnonzero(changed.any(axis=0))
    if rows.size == 0:
        return None
    nx, ny = clear.shape
    return (
        slice(max(0, int(rows[0]) - pad), min(nx, int(rows[-1]) + pad + 1)),
        slice(max(0, int(cols[0]) - pad), min(ny, int(cols[-1]) + pad + 1)),
    )


CARRY_SHARE = 0.5  # of the grid's cells, past which a box of changes is labelled afresh
# (a box spanning the arena cost 2.5 times a fresh labelling carried over)
FLOOD_BUDGET = 20_000  # configurations a flood meets before the labelling answers instead


class Reachability:
    """Answers "can the body get from this start to that goal at all?" for one lattice's free
    configurations: by the compiled flood fill from both ends (stopping when they meet) when
    kernels are available and it answers within ``flood_budget`` configurations, else by
    components: the earlier world's carried over where a few cells changed, when they keep
    start and goal apart, else every component labelled (``scipy.ndimage.label``); either
    is kept for the next question and the next world's."""

    def __init__(
        self,
        grid: LatticeGrid,
        table: MotionTable,
        at_centres: Array,
        margin: float,
        previous: Reachability | None = None,
    ) -> None:
        """``previous``: the answers for an earlier world model of the same lattice, body and
        margin, whose free configurations are updated where the clearance changed instead
        of made afresh (see ``free_configurations``)."""
        self.grid, self.table, self.margin = grid, table, margin
        self.last: bool | None = None  # the last answer
        # The earlier world kept start and goal apart: likely this one too, which the
        # components carried over tell sooner than a flood that runs out of its budget.
        self._apart = previous is not None and previous.last is False
        # Only labelled answers help, and holding one that is not would chain every version.
        if previous is not None and not previous.labelled:
            previous = previous._previous
        if previous is not None and (
            previous.table is not table or previous.grid is not grid or previous.margin != margin
        ):
            previous = None  # another body, lattice or margin: other free configurations
        self._previous: Reachability | None = previous
        self.at_centres = at_centres
        self.clear = np.ascontiguousarray(at_centres.reshape(grid.nx, grid.ny), dtype=float)
        self.rows = body_rows(grid, table, margin)
        self._labels: Components | None = None
        # Configurations the flood may meet before it leaves the question to the labelling
        # (two large components: a flood costs more per configuration than the labelling).
        self.flood_budget = FLOOD_BUDGET

    def reaches(
        self,
        start: Key,
        goal: tuple[float, float],
        reach: float,
        compiled: bool | None = None,
        flood_budget: int | None = None,
    ) -> bool:
        """``False`` only when no lattice plan can bring the head within ``reach`` of ``goal``
        from ``start`` (``True`` when one may, or when no configuration at the start passes
        the test: a robot touching something). ``compiled``: force the flood fill (True) or
        the labelling (False); by default the flood fill when kernels are available, within
        ``flood_budget`` configurations (default ``self.flood_budget``), then the components
        carried over from the earlier world's (see ``carried_over``), then labelling."""
        starts = self._starts(start)
        if starts.size == 0:
            return True
        self.last = self._reaches(starts, goal, self._limit(reach), compiled, flood_budget)
        return self.last

    def reaches_after(self, keys: Sequence[Key], goal: tuple[float, float], reach: float) -> bool:
        """Like ``reaches``, from any of the lattice states ``keys`` (where a plan's first
        motion may lead) that pass the test themselves: one that does not ends every plan
        through it there (the next motion's sweep begins with its resting body). ``False``
        when none does."""
        K, nx, ny = self.grid.settings.orientations, self.grid.nx, self.grid.ny
        free = {
            (k % K * nx + i) * ny + j
            for i, j, k in keys
            if 0 <= i < nx and 0 <= j < ny and self._free(k % K, i, j)
        }
        if not free:
            return False
        starts = np.asarray(sorted(free), dtype=np.int64)
        return self._reaches(starts, goal, self._limit(reach), None, None)

    def _limit(self, reach: float) -> float:
        """How far from the goal a head on a cell centre may lie: ``reach`` and half a cell
        diagonal (where the head really is, off the centre it is rounded to)."""
        return reach + self.grid.settings.resolution * math.sqrt(0.5)

    def _reaches(
        self,
        starts: NDArray[np.int64],
        goal: tuple[float, float],
        limit: float,
        compiled: bool | None,
        flood_budget: int | None,
    ) -> bool:
        if self._labels is not None and self._labels.exact:
            return self._answer(self._labels, starts, goal, limit)
        # The last world's components carried over (a few cells changed) answer a ``False``
        # soundly: the usual one is two large components that do not connect, which a flood
        # gives back when it runs out of its budget. Asked first when that is likely.
        if self._apart and self._apart_carried(starts, goal, limit):
            return False
        if compiled if compiled is not None else reach_kernel.AVAILABLE:
            grid = self.grid
            centres = grid.centres.reshape(grid.nx, grid.ny, 2)
            found = reach_kernel.flood_reaches(
                self.clear,
                *self.rows,
                np.asarray(self.table.heads, dtype=float),
                np.ascontiguousarray(centres[:, 0, 0]),
                np.ascontiguousarray(centres[0, :, 1]),
                goal,
                limit,
                starts,
                self.flood_budget if flood_budget is None else flood_budget,
            )
            if found is not None:
                return found
        if not self._apart and self._apart_carried(starts, goal, limit):
            return False
        return self._labelled_reaches(starts, goal, limit)

    def _apart_carried(
        self, starts: NDArray[np.int64], goal: tuple[float, float], limit: float
    ) -> bool:
        """Whether the components carried over from the earlier world (or exact ones, if
        nothing changed) keep start and goal apart."""
        if self._labels is None:
            self._labels = self._updated()
        return self._labels is not None and not self._answer(self._labels, starts, goal, limit)

    def held_bytes(self) -> int:
        """Bytes of the components it holds, its own and an earlier world's."""
        held = 0
        for known in (self._labels, self._previous._labels if self._previous else None):
            if known is not None:
                held += known.free.nbytes + known.labels.nbytes + known.component.nbytes
        return held

    @property
    def labelled(self) -> bool:
        """Whether every free configuration's component is known (a question needed it)."""
        return self._labels is not None

    def _labelled_reaches(
        self, starts: NDArray[np.int64], goal: tuple[float, float], limit: float
    ) -> bool:
        return self._answer(self._labelled(), starts, goal, limit)

    def _answer(
        self,
        known: Components,
        starts: NDArray[np.int64],
        goal: tuple[float, float],
        limit: float,
    ) -> bool:
        """Whether a configuration with the head on the goal shares a component with one of
        ``starts`` in ``known``."""
        grid = self.grid
        bins, cells = np.divmod(starts, grid.nx * grid.ny)
        mine = np.unique(known.component[known.labels[bins, *np.divmod(cells, grid.ny)]])
        centres = grid.centres.reshape(grid.nx, grid.ny, 2)
        xs, ys = centres[:, 0, 0], centres[0, :, 1]
        for k, (hx, hy) in enumerate(self.table.heads):
            # Only the cells round the goal (less the head's offset) can hold the head on it.
            i0, i1 = np.searchsorted(xs, [goal[0] - hx - limit, goal[0] - hx + limit])
            j0, j1 = np.searchsorted(ys, [goal[1] - hy - limit, goal[1] - hy + limit])
            box = (slice(max(0, i0 - 1), i1 + 1), slice(max(0, j0 - 1), j1 + 1))
            near = np.hypot(centres[*box, 0] + hx - goal[0], centres[*box, 1] + hy - goal[1])
            mask = (near <= limit) & known.free[k][box]
            if np.any(np.isin(known.component[known.labels[k][box][mask]], mine)):
                return True
        return False

    def _labelled(self) -> Components:
        """Every free configuration's component, exactly (built on the first question that
        needs it, from the free configurations of an update if one was made)."""
        if self._labels is None or not self._labels.exact:
            free = self._labels.free if self._labels is not None else self._free_configurations()
            self._labels = exact_components(free)
        return self._labels

    def _free_configurations(self) -> NDArray[np.bool_]:
        earlier, self._previous = self._previous, None
        known = None
        if earlier is not None and earlier._labels is not None:
            known = (earlier.at_centres, earlier._labels.free)
        return free_configurations(
            self.grid, self.table, self.at_centres, self.margin, self.rows, known
        )

    def _updated(self) -> Components | None:
        """The earlier world's components carried over to this one (``None`` without one,
        or when the changes' box spans more than ``CARRY_SHARE`` of the grid):
        the cells whose configurations may have changed are labelled afresh and joined with
        the earlier components they touch, which are kept elsewhere. A component may so
        come out joined with one it no longer connects with (something sensed since cut
        them apart), never apart from one it connects with: a ``False`` from these is sound,
        a ``True`` is asked again of the exact labelling."""
        earlier = self._previous
        if earlier is None or earlier._labels is None:
            return None
        old = earlier._labels
        cap = float(self.rows.thresholds.max())
        box = changed_box(self.clear, earlier.clear, body_pad(self.grid, self.table), cap)
        if box is None:
            self._previous = None
            return old  # nothing changed
        area = (box[0].stop - box[0].start) * (box[1].stop - box[1].start)
        if area > CARRY_SHARE * self.grid.nx * self.grid.ny:
            return None  # changes all over: labelling afresh costs less
        free = self._free_configurations()
        # Taken over, not copied (a large array): an earlier world's question is not asked
        # again once a later one's is; if it were, it would be answered afresh.
        earlier._labels = None
        return carried_over(old, free, box)

    def _starts(self, start: Key) -> NDArray[np.int64]:
        """The free configurations at ``start`` or, when the snapped state itself fails the
        test (the robot stands closer to something than the margin), next to it: one cell and
        one orientation step around, where the real pose lies (numbers ``(k * nx + i) * ny +
        j``)."""
        si, sj, sk = start
        grid = self.grid
        K, nx, ny = grid.settings.orientations, grid.nx, grid.ny
        found = []
        for dk in (0, -1, 1):
            for di in (0, -1, 1):
                for dj in (0, -1, 1):
                    k, i, j = (sk + dk) % K, si + di, sj + dj
                    if 0 <= i < nx and 0 <= j < ny and self._free(k, i, j):
                        found.append((k * nx + i) * ny + j)
            if found and dk == 0:
                break  # the start's own orientation decides when it can
        return np.asarray(found, dtype=np.int64)

    def _free(self, k: int, i: int, j: int) -> bool:
        return reach_kernel.configuration_free(self.clear, *self.rows, k, i, j)

"""Whether the body can rest at lattice states: the check a partial plan's last state needs.

Every motion checks the body at rest where it starts (a state's representative pose is where
the previous move landed, snapped to the lattice up to 3.5 cm away, so that move did not check
it). A plan's last state starts no motion: a partial plan could end where the snapped body
overlaps an obstacle, and the robot drove into it getting there (``examples/untuned6/
zslot-018-deform-*``: a 5 cm move of the arc body snapped 2 cm further, its tail onto a known
wall), so ``leg_search`` drops such a last move. Goal visits are not held to it: tried, at 5 cm
of range noise the phantom cells round a goal made a reachable goal ``unreachable``.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from domain.lattice import LatticeGrid, MotionTable
from sim.robot import Array


def can_rest(
    grid: LatticeGrid,
    table: MotionTable,
    clearance: Callable[[Array], Array],
    numbers: NDArray[np.int64],
    margin: float,
) -> NDArray[np.bool_]:
    """Per state number: whether the body at rest there keeps ``margin`` clear, as a motion
    out of it checks its start (``clearance``: metres at world points ``[N, 2]``)."""
    numbers = np.asarray(numbers, dtype=np.int64)
    out = np.zeros(len(numbers), dtype=bool)
    if numbers.size == 0:
        return out
    k, cell = np.divmod(numbers, grid.nx * grid.ny)  # encode(): (k * nx + i) * ny + j
    centres = grid.centres[cell]
    for bin_ in np.unique(k).tolist():
        rows = np.flatnonzero(k == bin_)
        body: Array = table.body_points[bin_]
        points = centres[rows, None, :] + body[None, :, :]  # [S, P, 2]
        clear = clearance(points.reshape(-1, 2)).reshape(len(rows), -1)
        out[rows] = np.all(clear >= table.body_needs[bin_] + margin, axis=1)
    return out

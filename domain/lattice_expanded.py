"""What a compiled search leaves for the PDDL export: the expanded states' successors, and the
states where the head is on the goal (the states a goal visit may leave).

The compiled search (domain/lattice_search.py) records each state it expands with its free
motions as a bitmask; ``fill_expanded`` turns them into ``LatticeTask.edges`` and ``near`` as
``get_successor_states`` would have filled them, when they are first read. ``near_goal_states``
lists the states ``is_near`` holds for, for the search to look up.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from domain.lattice_task import LatticeTask


def fill_expanded(
    task: LatticeTask,
    numbers: NDArray[np.int64],
    bits: NDArray[np.int64],
    near: NDArray[np.bool_],
    edges: dict[int, list[tuple[int, str]]],
    near_states: set[int],
) -> None:
    """Add to ``edges`` and ``near_states`` what expanding ``numbers`` (in order, with free
    motions ``bits``, bit ``m`` for motion ``m``, and ``near`` the goal) hands out: every move
    that leaves the state (inside the task's window, if it has one), by motion index. A state
    expanded again keeps its first successors (as ``get_successor_states`` does)."""
    near_states.update(numbers[near].tolist())
    _, first = np.unique(numbers, return_index=True)
    first = np.sort(first)
    first = first[[n not in edges for n in numbers[first].tolist()]]
    numbers, bits = numbers[first], bits[first]
    names = np.array(task.table.names, dtype=object)
    ny = task.grid.ny
    plane = task.grid.nx * ny
    k, cell = np.divmod(numbers, plane)
    free = ((bits[:, None] >> np.arange(len(names), dtype=np.int64)) & 1).astype(bool)
    after = task.motion_targets[k] + cell[:, None]  # [S, M] next state numbers
    free &= after != numbers[:, None]  # a move that stays is no successor
    if task.window is not None:
        (wi, wj), (i, j) = task.window, np.divmod(after % plane, ny)
        free &= (i >= wi.start) & (i < wi.stop) & (j >= wj.start) & (j < wj.stop)
    rows, cols = np.nonzero(free)  # row by row, by motion index
    pairs = list(zip(after[rows, cols].tolist(), names[cols].tolist(), strict=True))
    ends = np.cumsum(free.sum(axis=1)).tolist()
    start = 0
    for number, end in zip(numbers.tolist(), ends, strict=True):
        edges[number] = pairs[start:end]
        start = end


def near_goal_states(task: LatticeTask) -> NDArray[np.int64]:
    """Every state where the head is on the task's goal (``is_near``), sorted: the cells round
    the goal, by the same arithmetic as ``is_near`` (numpy's ``hypot`` may differ from
    ``math.hypot`` in the last place, so states within a hair of the reach ask ``is_near``)."""
    grid, r, b = task.grid, task.grid.settings.resolution, task.grid.bounds
    gx, gy = task.goal
    heads = np.asarray(task.table.heads, dtype=np.float64)  # [K, 2]
    half = math.ceil(task.reach / r) + 2
    span = np.arange(-half, half + 1)
    # Per bin, the cells round the one whose head lies on the goal.
    ci = np.floor((gx - heads[:, 0] - b.xmin) / r).astype(np.int64)[:, None, None]
    cj = np.floor((gy - heads[:, 1] - b.ymin) / r).astype(np.int64)[:, None, None]
    i, j = ci + span[None, :, None], cj + span[None, None, :]  # [K, S, 1], [K, 1, S]
    x = b.xmin + (i + 0.5) * r + heads[:, 0, None, None]
    y = b.ymin + (j + 0.5) * r + heads[:, 1, None, None]
    d = np.hypot(x - gx, y - gy)  # [K, S, S]
    on = (i >= 0) & (i < grid.nx) & (j >= 0) & (j < grid.ny)
    near = on & (d <= task.reach)
    unsure = on & (np.abs(d - task.reach) <= 1e-12 * max(1.0, task.reach))
    for k, a, c in zip(*np.nonzero(unsure), strict=True):
        key = (int(ci[k, 0, 0] + span[a]), int(cj[k, 0, 0] + span[c]), int(k))
        near[k, a, c] = task.is_near(key)
    k, a, c = np.nonzero(near)
    numbers = (k * grid.nx + ci[k, 0, 0] + span[a]) * grid.ny + cj[k, 0, 0] + span[c]
    return np.sort(numbers.astype(np.int64))

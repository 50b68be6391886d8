"""Orders unordered goals: the shortest tour by a goal-to-goal distance table (every
permutation up to ``MAX_GOALS_EXACT`` goals, else nearest neighbour then 2-opt), never by
multiplying the planner's state space by the goals."""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

from sim.robot import Array

MAX_GOALS_EXACT = 7  # unordered goals up to this many are ordered by trying every permutation


@dataclass(frozen=True)
class LegGoal:
    """A goal of the tour: its index in the mission, position and tolerance."""

    index: int
    x: float
    y: float
    tolerance: float


class Cells(Protocol):
    """A grid that names the cell of a point (a planner's lattice grid)."""

    def cell(self, x: float, y: float) -> tuple[int, int]: ...


def order_goals(
    grid: Cells, goals: Sequence[LegGoal], maps: dict[int, Array], start: tuple[int, int]
) -> list[LegGoal]:
    """The tour through ``goals`` from ``start`` (a cell) that is shortest by ``maps`` (each
    goal's distance map, metres)."""

    def d(a: tuple[int, int], g: LegGoal) -> float:
        return float(maps[g.index][a])

    cells = {g.index: grid.cell(g.x, g.y) for g in goals}

    def tour_length(tour: Sequence[LegGoal]) -> float:
        total, here = 0.0, start
        for g in tour:
            total += d(here, g)
            here = cells[g.index]
        return total

    if len(goals) <= MAX_GOALS_EXACT:
        return list(min(itertools.permutations(goals), key=lambda t: tour_length(list(t))))
    tour, here, todo = [], start, list(goals)
    while todo:  # nearest neighbour, then 2-opt
        g = min(todo, key=lambda x: d(here, x))
        tour.append(g)
        todo.remove(g)
        here = cells[g.index]
    improved = True
    while improved:
        improved = False
        for a, b in itertools.combinations(range(len(tour)), 2):
            candidate = tour[:a] + tour[a : b + 1][::-1] + tour[b + 1 :]
            if tour_length(candidate) < tour_length(tour) - 1e-9:
                tour, improved = candidate, True
    return tour

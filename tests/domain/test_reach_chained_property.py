"""Seeded random chains of worlds: a ``Reachability`` carried over from the last world answers
every question as one made afresh and labelled (discs sensed and cleared, pens closed and
opened, changes at the arena's edges, starts at the orientations either side of the wrap),
whether the flood runs out of its budget at once or never; and a pen closed inside the changed
box is apart in the carried-over components."""

from __future__ import annotations

import numpy as np
import pytest

from domain import reach_kernel
from domain.lattice import LatticeGrid, LatticeSettings, motion_table
from domain.lattice_reach import Reachability
from domain.reach_components import carried_over, exact_components
from primitives.library import load_bundled
from primitives.shapes import SHAPES
from sim.world import Bounds
from tests.domain.disc_scenes import clearance

SETTINGS = LatticeSettings()
LIBRARY = load_bundled()
# Not square, so that a row/column mix-up shows.
BOUNDS = Bounds(-1.5, 1.5, -1.2, 1.3)
Disc = tuple[float, float, float]
Pen = tuple[float, float, float, int]  # centre, radius, discs left out (0: closed)


def pen_discs(cx: float, cy: float, radius: float, gap: int, n: int = 40) -> list[Disc]:
    """Small discs on a circle, less ``gap`` of them (a way in)."""
    a = np.linspace(0, 2 * np.pi, n, endpoint=False)
    a = np.r_[a[: n // 2], a[n // 2 + gap :]]
    return [(cx + radius * np.cos(t), cy + radius * np.sin(t), 0.06) for t in a]


def changed(rng: np.random.Generator, discs: list[Disc], pens: list[Pen]) -> None:
    """One change of the world, in place."""
    op = int(rng.integers(7))
    if op == 0 or (op == 1 and not discs):
        discs.append((*rng.uniform([-1.4, -1.1], [1.4, 1.2]), float(rng.uniform(0.05, 0.3))))
    elif op == 1:
        discs.pop(int(rng.integers(len(discs))))
    elif op == 2:  # at an edge of the arena
        t, e = float(rng.uniform(-1.1, 1.1)), float(rng.uniform(1.0, 1.2))
        x, y = [(e, t), (-e, t), (t, e), (t, -e)][int(rng.integers(4))]
        discs.append((x, y, float(rng.uniform(0.05, 0.25))))
    elif op == 3 and pens:  # a pen opened or closed
        i = int(rng.integers(len(pens)))
        cx, cy, radius, gap = pens[i]
        pens[i] = (cx, cy, radius, 0 if gap else int(rng.integers(5, 10)))
    elif op == 4:
        centre = rng.uniform(-0.8, 0.8, 2)
        pens.append((*centre, float(rng.uniform(0.35, 0.55)), int(rng.choice([0, 7]))))
    elif op == 5 and discs:  # a disc nudged a little
        i = int(rng.integers(len(discs)))
        x, y, r = discs[i]
        discs[i] = (x + rng.normal(0, 0.03), y + rng.normal(0, 0.03), max(0.02, r + 0.01))
    # else: nothing changed (the same world again)


@pytest.mark.parametrize("seed", range(6))
def test_chained_answers_as_made_afresh(seed: int) -> None:
    rng = np.random.default_rng(seed)
    shape = ["straight", "zigzag", "arc"][seed % 3]
    table = motion_table(LIBRARY, shape, SHAPES[shape].joints, SETTINGS)
    assert table is not None
    grid = LatticeGrid(BOUNDS, SETTINGS)
    K = SETTINGS.orientations
    compiled = None if seed % 2 and reach_kernel.AVAILABLE else False
    budget = [1, 10**7][(seed // 2) % 2]  # the flood gives up at once, or never
    discs: list[Disc] = []
    pens: list[Pen] = [(0.7, 0.6, 0.5, 0)]
    chained: Reachability | None = None
    answers = []
    for world in range(int(rng.integers(4, 9))):
        if world:
            for _ in range(int(rng.integers(1, 3))):
                changed(rng, discs, pens)
        at = clearance(grid, discs + [d for p in pens for d in pen_discs(*p)])
        chained = Reachability(grid, table, at, 0.01, previous=chained)
        fresh = Reachability(grid, table, at, 0.01)
        for _ in range(14):
            i, j = int(rng.integers(grid.nx)), int(rng.integers(grid.ny))
            if pens and rng.uniform() < 0.4:  # a start in a pen
                cx, cy = pens[int(rng.integers(len(pens)))][:2]
                i, j = grid.cell(cx + rng.normal(0, 0.1), cy + rng.normal(0, 0.1))
            k = int(rng.choice([0, 1, K - 2, K - 1, int(rng.integers(K))]))
            goal = (float(rng.uniform(-1.5, 1.5)), float(rng.uniform(-1.2, 1.3)))
            if rng.uniform() < 0.3:
                goal = pens[0][:2]
            reach = float(rng.choice([0.03, 0.08, 0.2]))
            got = chained.reaches((i, j, k), goal, reach, compiled=compiled, flood_budget=budget)
            want = fresh.reaches((i, j, k), goal, reach, compiled=False)
            assert got == want, (world, (i, j, k), goal, reach)
            answers.append(want)
    assert False in answers and True in answers  # (questions that can fail both ways)


def test_a_pen_closed_inside_the_box_is_apart_in_the_carried_components() -> None:
    """Old and new labels are joined only on the box's frame (ring less box): a pen closed
    since, its inside unchanged but inside the box, comes out apart from the rest (joined
    wherever old and new were both free, it stayed joined by its old labels)."""
    K, n = 4, 30
    before = np.ones((K, n, n), dtype=bool)
    before[:, 10, 10:21] = before[:, 20, 10:21] = False  # a pen's walls
    before[:, 10:21, 10] = before[:, 10:21, 20] = False
    before[:, 10, 14:17] = True  # its way in
    after = before.copy()
    after[:, 10, 14:17] = False  # closed
    carried = carried_over(exact_components(before), after, (slice(8, 23), slice(8, 23)))
    component = carried.component[carried.labels]
    assert component[0, 15, 15] != component[0, 2, 2]  # inside, outside
    assert component[0, 2, 2] == component[3, 28, 28]  # (the outside stays one)

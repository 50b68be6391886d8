"""Loading what navigation reuses before a mission needs it: tables and compiled kernels."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from domain.navigation.feasibility import Feasibility, body_rows
from domain.navigation.lattice.costs import kernel_table
from domain.navigation.lattice.grid import LatticeGrid
from domain.navigation.lattice.motions import HeadView, held_joints, motion_table
from domain.navigation.settings import NavigationSettings
from primitives.library import Library
from primitives.shapes import shape_named
from sim.world import Bounds


def warm_tables(
    library: Library,
    settings: NavigationSettings,
    view: HeadView | None = None,
    shapes: Sequence[str] | None = None,
) -> int:
    """Every library shape's motion table (or only ``shapes``': a shape just learned) with its
    kernel forms and resting-body rows, and the feasibility flood compiled once: what a reshape
    or a first plan would otherwise pay for inside a mission. Returns how many tables it made."""
    grid = LatticeGrid(Bounds(-1.0, 1.0, -1.0, 1.0), settings)
    made = 0
    for shape in library.lattice_shapes() if shapes is None else shapes:
        table = motion_table(library, shape, held_joints(shape_named(shape).joints), settings, view)
        if table is None:
            continue
        made += 1
        kernel_table(table, settings.margin)
        kernel_table(table, settings.start_margin)
        body_rows(grid, table, settings.margin)
        if made == 1:  # the flood's kernels, once
            check = Feasibility(grid, table, np.full((grid.nx, grid.ny), 1.0), settings.margin)
            check.reaches((grid.nx // 2, grid.ny // 2, 0), (0.5, 0.5), 0.1)
    return made

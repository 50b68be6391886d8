"""Clearance of scenes made of discs on a lattice grid, for the reachability tests."""

from __future__ import annotations

import numpy as np

from domain.lattice import LatticeGrid


def clearance(grid: LatticeGrid, discs: list[tuple[float, float, float]]) -> np.ndarray:
    """Metres from each cell centre to the nearest disc or wall."""
    c, b = grid.centres, grid.bounds
    out = np.minimum.reduce(
        [c[:, 0] - b.xmin, b.xmax - c[:, 0], c[:, 1] - b.ymin, b.ymax - c[:, 1]]
    )
    for x, y, r in discs:
        out = np.minimum(out, np.hypot(c[:, 0] - x, c[:, 1] - y) - r)
    return out

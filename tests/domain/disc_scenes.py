"""Clearance of scenes made of discs on a lattice grid, for the feasibility tests."""

from __future__ import annotations

import numpy as np

from domain.navigation import LatticeGrid


def clearance(grid: LatticeGrid, discs: list[tuple[float, float, float]]) -> np.ndarray:
    """Metres from each cell centre to the nearest disc or wall ``[nx, ny]``."""
    c, b = grid.centres, grid.bounds
    out = np.minimum.reduce(
        [c[:, 0] - b.xmin, b.xmax - c[:, 0], c[:, 1] - b.ymin, b.ymax - c[:, 1]]
    )
    for x, y, r in discs:
        out = np.minimum(out, np.hypot(c[:, 0] - x, c[:, 1] - y) - r)
    return out.reshape(grid.nx, grid.ny)


def ring(x: float, y: float, radius: float, n: int = 40) -> list[tuple[float, float, float]]:
    """Small discs on a circle: a closed pen round (x, y)."""
    a = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return [(x + radius * np.cos(t), y + radius * np.sin(t), 0.06) for t in a]

"""The cells many range readings' beams swept, found at once (the clearing half of an update).

Each reading clears the cells its ray or cone swept up to a range (``sector_points`` samples
them). A tick brings a dozen readings; sampling, locating and de-duplicating them one by one is
a dozen numpy calls each on a few hundred points. ``swept_cells`` samples every reading's
beam in one pass, with the same arithmetic element by element (so the same points, hence the same
cells), and de-duplicates per reading with one ``unique`` over (reading, cell) keys.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from domain.grid import Flat, Grid, unique_cells
from domain.observation import RangeObservation
from sim.robot import Array


def cone_angles(obs: RangeObservation, reach: float, step: float) -> Array:
    """Ray directions (angles) covering the cone out to ``reach`` at most ``step`` apart there."""
    n = 1 if obs.fov == 0 else math.ceil(obs.fov * reach / step) + 1
    if n > 1:
        out: Array = obs.angle + np.linspace(-obs.fov / 2, obs.fov / 2, n)
        return out
    return np.array([obs.angle])


def cone_directions(obs: RangeObservation, reach: float, step: float) -> Array:
    """Unit vectors ``[n, 2]`` of ``cone_angles``."""
    angles = cone_angles(obs, reach, step)
    return np.stack([np.cos(angles), np.sin(angles)], axis=-1)


def sector_points(obs: RangeObservation, until: float, step: float) -> Array:
    """Sample points ``[N, 2]`` filling the sensor's cone (or ray) from its origin to ``until``."""
    if until <= 0:
        return np.zeros((0, 2))
    rho = np.arange(0.0, until, step)
    dirs = cone_directions(obs, until, step)
    return (np.asarray(obs.origin) + rho[:, None, None] * dirs[None, :, :]).reshape(-1, 2)


def swept_cells(
    grid: Grid, readings: Sequence[tuple[RangeObservation, float]], step: float
) -> tuple[NDArray[np.intp], Flat]:
    """For readings given as (observation, clear-until range): which reading (its position in
    ``readings``) swept which cell, each pair once, as ``sector_points`` would sample them.

    Returns parallel arrays (reading index, flat cell), sorted by reading then cell.
    """
    angles, rhos, owners = [], [], []
    for k, (obs, until) in enumerate(readings):
        if until <= 0:
            continue
        angles.append(cone_angles(obs, until, step))
        # np.arange fills start + i * step: the same values as i * step from 0
        rhos.append(np.arange(0.0, until, step))
        owners.append(k)
    if not owners:
        return np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp)
    n_dirs = np.array([a.size for a in angles])
    n_rho = np.array([r.size for r in rhos])
    all_angles = np.concatenate(angles)
    dirs = np.stack([np.cos(all_angles), np.sin(all_angles)], axis=-1)  # [D, 2]
    origins = np.array([readings[k][0].origin for k in owners], dtype=float)  # [K, 2]
    # One sample per (reading, range step, direction), in sector_points' order within a reading.
    per = n_dirs * n_rho
    reading = np.repeat(np.arange(len(owners)), per)
    within = np.arange(reading.size) - np.repeat(np.cumsum(per) - per, per)
    rho_i, dir_i = np.divmod(within, n_dirs[reading])
    rho = np.concatenate(rhos)[np.repeat(np.cumsum(n_rho) - n_rho, per) + rho_i]
    direction = dirs[np.repeat(np.cumsum(n_dirs) - n_dirs, per) + dir_i]
    points = origins[reading] + rho[:, None] * direction
    flat, keep = grid.locate(points)
    cells = grid.nx * grid.ny
    keys = unique_cells(reading[keep] * cells + flat[keep])
    which, cell = np.divmod(keys, cells)
    return np.asarray(owners, dtype=np.intp)[which], cell

"""The cells many range readings' beams swept, found at once (the clearing half of an update).

Each reading clears the cells its ray or cone swept up to a range (``sector_points`` samples
them). A tick brings a dozen readings; sampling, locating and de-duplicating them one by one is
a dozen numpy calls each on a few hundred points. ``swept_cells`` samples every reading's
beam in one pass, with the same arithmetic element by element (so the same points, hence the same
cells), and de-duplicates per reading with one ``unique`` over (reading, cell) keys.
"""

from __future__ import annotations

import functools
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


@functools.lru_cache(maxsize=256)
def _spread(fov: float, n: int) -> tuple[float, ...]:
    """``np.linspace(-fov / 2, fov / 2, n)`` as floats (a cone's ray offsets; few distinct ones)."""
    return tuple(np.linspace(-fov / 2, fov / 2, n).tolist())


def swept_cells(
    grid: Grid, readings: Sequence[tuple[RangeObservation, float]], step: float
) -> tuple[NDArray[np.intp], Flat]:
    """For readings given as (observation, clear-until range): which reading (its position in
    ``readings``) swept which cell, each pair once, as ``sector_points`` would sample them.

    Returns parallel arrays (reading index, flat cell), sorted by reading then cell.
    """
    angles: list[float] = []
    n_dirs, n_rho, owners = [], [], []
    for k, (obs, until) in enumerate(readings):
        if until <= 0:
            continue
        n = 1 if obs.fov == 0 else math.ceil(obs.fov * until / step) + 1  # as cone_angles
        if n > 1:
            angles += [obs.angle + offset for offset in _spread(obs.fov, n)]
        else:
            angles.append(obs.angle)
        n_dirs.append(n)
        n_rho.append(math.ceil(until / step))  # len(np.arange(0.0, until, step))
        owners.append(k)
    if not owners:
        return np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp)
    all_angles = np.array(angles)
    dirs = np.stack([np.cos(all_angles), np.sin(all_angles)], axis=-1)  # [D, 2]
    origins = np.array([readings[k][0].origin for k in owners], dtype=float)  # [K, 2]
    dir_counts, rho_counts = np.array(n_dirs), np.array(n_rho)
    # One sample per (reading, range step, direction), in sector_points' order within a reading.
    per = dir_counts * rho_counts
    reading = np.repeat(np.arange(len(owners)), per)
    within = np.arange(reading.size) - np.repeat(np.cumsum(per) - per, per)
    rho_i, dir_i = np.divmod(within, dir_counts[reading])
    rho = rho_i * step  # np.arange(0.0, until, step) holds exactly i * step
    direction = dirs[np.repeat(np.cumsum(dir_counts) - dir_counts, per) + dir_i]
    points = origins[reading] + rho[:, None] * direction
    flat, keep = grid.locate(points)
    cells = grid.nx * grid.ny
    keys = unique_cells(reading[keep] * cells + flat[keep])
    which, cell = np.divmod(keys, cells)
    return np.asarray(owners, dtype=np.intp)[which], cell

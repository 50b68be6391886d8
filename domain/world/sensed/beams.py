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

from domain.world.grid import Flat, Grid, unique_cells, unique_inverse
from domain.world.observation import RangeObservation
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
def spread(fov: float, n: int) -> tuple[float, ...]:
    """``np.linspace(-fov / 2, fov / 2, n)`` as floats (a cone's ray offsets; few distinct ones)."""
    return tuple(np.linspace(-fov / 2, fov / 2, n).tolist())


def _fan(
    readings: Sequence[RangeObservation], reach: Sequence[float], n_rho: Sequence[int], step: float
) -> tuple[NDArray[np.intp], NDArray[np.intp], Array]:
    """Sample points of several cones: for reading k, ``n_rho[k]`` ranges by ``cone_angles``
    out to ``reach[k]``, range-major as ``sector_points`` orders them. Returns each sample's
    reading, its range index within the reading, and the unit direction ``[N, 2]``."""
    angles: list[float] = []
    n_dirs = []
    for obs, r in zip(readings, reach, strict=True):
        n = 1 if obs.fov == 0 else math.ceil(obs.fov * r / step) + 1  # as cone_angles
        if n > 1:
            angles += [obs.angle + offset for offset in spread(obs.fov, n)]
        else:
            angles.append(obs.angle)
        n_dirs.append(n)
    all_angles = np.array(angles)
    dirs = np.stack([np.cos(all_angles), np.sin(all_angles)], axis=-1)  # [D, 2]
    dir_counts, rho_counts = np.array(n_dirs), np.asarray(n_rho)
    per = dir_counts * rho_counts
    reading = np.repeat(np.arange(len(readings)), per)
    within = np.arange(reading.size) - np.repeat(np.cumsum(per) - per, per)
    rho_i, dir_i = np.divmod(within, dir_counts[reading])
    direction = dirs[np.repeat(np.cumsum(dir_counts) - dir_counts, per) + dir_i]
    return reading, rho_i, direction


def swept_cells(
    grid: Grid, readings: Sequence[tuple[RangeObservation, float]], step: float
) -> tuple[NDArray[np.intp], Flat]:
    """For readings given as (observation, clear-until range): which reading (its position in
    ``readings``) swept which cell, each pair once, as ``sector_points`` would sample them.

    Returns parallel arrays (reading index, flat cell), sorted by reading then cell.
    """
    owners = [k for k, (_, until) in enumerate(readings) if until > 0]
    if not owners:
        return np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp)
    beams = [readings[k][0] for k in owners]
    until = [readings[k][1] for k in owners]
    n_rho = [math.ceil(u / step) for u in until]  # len(np.arange(0.0, until, step))
    reading, rho_i, direction = _fan(beams, until, n_rho, step)
    origins = np.array([obs.origin for obs in beams], dtype=float)  # [K, 2]
    rho = rho_i * step  # np.arange(0.0, until, step) holds exactly i * step
    points = origins[reading] + rho[:, None] * direction
    flat, keep = grid.locate(points)
    cells = grid.nx * grid.ny
    keys = unique_cells(reading[keep] * cells + flat[keep])
    which, cell = np.divmod(keys, cells)
    return np.asarray(owners, dtype=np.intp)[which], cell


@functools.lru_cache(maxsize=64)
def likelihoods(n: int) -> tuple[Array, Array]:
    """Standard scores ``z`` across ±2σ in ``n`` samples and their Gaussian weights."""
    z = np.linspace(-2.0, 2.0, n) if n > 1 else np.zeros(1)
    weights = np.exp(-0.5 * z * z)
    z.flags.writeable = weights.flags.writeable = False
    return z, weights


def hit_points(obs: RangeObservation, distance: float, step: float) -> tuple[Array, Array]:
    """Where the hit may be: sample points ``[N, 2]`` across the cone over ``distance`` ± 2σ of
    the sensor's noise, with their Gaussian range likelihoods ``[N]``."""
    n = 2 * math.ceil(2.0 * obs.noise_std / step) + 1
    z, likelihood = likelihoods(n)
    rho = np.maximum(distance + obs.noise_std * z, 0.0)
    dirs = cone_directions(obs, distance, step)
    points = np.asarray(obs.origin) + rho[:, None, None] * dirs[None, :, :]
    weights = np.broadcast_to(likelihood[:, None], points.shape[:2])
    return points.reshape(-1, 2), weights.reshape(-1)


def arc_cells(
    grid: Grid, hits: Sequence[tuple[RangeObservation, float]], step: float
) -> list[tuple[Flat, Array]]:
    """For readings that hit (observation, measured range): the cells where each hit may lie
    and their summed range likelihoods, as ``hit_points`` samples them, all in one pass."""
    if not hits:
        return []
    beams = [obs for obs, _ in hits]
    distance = np.array([d for _, d in hits])
    sigma = np.array([obs.noise_std for obs in beams])
    n_z = [2 * math.ceil(2.0 * obs.noise_std / step) + 1 for obs in beams]
    reading, z_i, direction = _fan(beams, [d for _, d in hits], n_z, step)
    z_all = np.concatenate([likelihoods(n)[0] for n in n_z])
    w_all = np.concatenate([likelihoods(n)[1] for n in n_z])
    first_z = np.cumsum(n_z) - n_z
    z = z_all[first_z[reading] + z_i]
    rho = np.maximum(distance[reading] + sigma[reading] * z, 0.0)
    origins = np.array([obs.origin for obs in beams], dtype=float)
    points = origins[reading] + rho[:, None] * direction
    flat, keep = grid.locate(points)
    cells = grid.nx * grid.ny
    keys, inverse = unique_inverse(reading[keep] * cells + flat[keep])
    # per key, the likelihoods summed in sample order (as one bincount per reading would)
    sums = np.bincount(inverse, weights=w_all[first_z[reading] + z_i][keep], minlength=keys.size)
    which, cell = np.divmod(keys, cells)
    bounds = np.searchsorted(which, np.arange(len(hits) + 1))
    return [
        (cell[bounds[k] : bounds[k + 1]], np.asarray(sums[bounds[k] : bounds[k + 1]], np.float64))
        for k in range(len(hits))
    ]

"""The sensed occupancy layer: a log-odds grid updated by range readings (ray clearing, cone hits).

Clearing before marking: every reading first clears the cells its ray or cone swept, up to the
measured range minus a noise margin (2σ + half a cell; a reading of "nothing within range" clears
the cone to ``max_range`` minus the same margin, since an obstacle just inside the range may read
as out of it). Then the hit is placed where it may be: across the cone, over the measured range
± 2σ. A cone's one reading is the nearest hit anywhere in the cone, so that region only says "at
least one of these cells is occupied". Its evidence (``log_odds_hit`` in all) is shared across the
region's cells in proportion to range likelihood x current occupancy probability, so cells other
beams cleared get little and cells known occupied get most. A cell's share counts in full only if
it holds most of the evidence (``dominant_share``) and the cone's arc at that range is at most a
cell wide (``unambiguous_arc``); any other share may lift a cell only up to ``ambiguous_ceiling``,
below the occupied threshold. Cells cleared around a wide arc prove nothing about the one left
standing, and the same ambiguous arc read over and over is not new evidence: so a cone straddling
a free corridor and reading its wall at the edge never fills the corridor, however long it stares,
while single rays and the cone close in mark obstacles after a few consistent readings. Hits within
the noise of known geometry (known obstacles, arena walls) are the known geometry's and leave the
sensed layer alone, so known walls are not narrowed by noisy copies of themselves.

Readings come in as ``RangeObservation``s; ``range_observations`` builds them from the head's
sensor layout (``sim.sensors``), a tracked pose and the readings by sensor name.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import NDArray

from sim.robot import DEFAULT_GEOMETRY, Array, RobotGeometry, head_tip
from sim.sensors import RangeSensor
from sim.world import Bounds

Flat = NDArray[np.intp]


@dataclass(frozen=True)
class RangeObservation:
    """One range reading in the world frame, with the sensor's geometry."""

    origin: tuple[float, float]  # sensor position, world frame (m)
    angle: float  # cone axis direction, world frame (rad)
    fov: float  # full cone width (rad); 0 = a single ray
    max_range: float  # m
    distance: float  # measured range (m); NaN = no reading (dropout): ignored
    hit: bool  # False: "nothing within max_range" (distance == max_range)
    noise_std: float = 0.0  # the sensor's stated noise (m)

    def __post_init__(self) -> None:
        values = (*self.origin, self.angle, self.fov, self.max_range, self.noise_std)
        if not all(math.isfinite(v) for v in values):
            raise ValueError(
                "range observation: origin, angle, fov, max_range, noise must be finite"
            )
        if self.fov < 0 or self.fov >= math.pi or self.max_range <= 0 or self.noise_std < 0:
            raise ValueError("range observation: need 0 <= fov < pi, max_range > 0, noise_std >= 0")
        if not (math.isnan(self.distance) or self.distance >= 0):
            raise ValueError("range observation: distance must be >= 0 or NaN")


def range_observations(
    sensors: Sequence[RangeSensor],
    pose: Sequence[float] | Array,
    ranges: Mapping[str, float],
    geometry: RobotGeometry = DEFAULT_GEOMETRY,
    no_hit_sigmas: float = 2.0,
) -> list[RangeObservation]:
    """The head's range readings (``sim.sensors`` layout) at tracked pose ``[x, y, ψ]`` as
    observations. A missing or NaN reading is a dropout; one within ``no_hit_sigmas`` noise σ of
    ``max_range`` means "nothing within range" (an empty reading is noisy too, then clipped)."""
    p = np.asarray(pose, dtype=float)
    origin = head_tip(p, geometry)
    at = (float(origin[0]), float(origin[1]))
    forward = float(p[2]) + math.pi  # the head leads: the body trails along ψ
    out = []
    for sensor in sensors:
        d = float(ranges.get(sensor.name, math.nan))
        fov = sensor.fov if sensor.rays > 1 else 0.0  # one ray reads along the axis only
        hit = not math.isnan(d) and d < sensor.max_range - no_hit_sigmas * sensor.noise_std
        angle = forward + sensor.angle
        out.append(RangeObservation(at, angle, fov, sensor.max_range, d, hit, sensor.noise_std))
    return out


@dataclass(frozen=True)
class WorldModelSettings:
    """Every limit of the world model; log-odds are natural logarithms of the odds."""

    resolution: float = 0.05  # m per cell
    log_odds_free: float = -0.4  # per reading, for each cell its beam cleared
    log_odds_hit: float = 0.85  # one reading's hit evidence, shared across its arc cells
    log_odds_min: float = -2.0  # clamps keep the layer responsive to change
    log_odds_max: float = 3.5
    occupied_threshold: float = 1.5  # two consistent single-ray hits (2 x 0.85) cross it
    ambiguous_ceiling: float = 1.0  # an ambiguous arc share raises a cell at most to this
    dominant_share: float = 0.5  # an arc cell holding more of the evidence than this is unambiguous
    unambiguous_arc: float = 1.0  # ... if the cone's arc at the hit is at most this many cells wide
    clear_sigmas: float = 2.0  # clearing stops this many noise σ short of the measured range ...
    clear_margin: float = 0.025  # ... plus this (m)
    explained_sigmas: float = 2.0  # a hit within this many σ + half a cell diagonal of known
    # geometry is explained by it and leaves the sensed layer alone
    sample_step: float = 0.5  # beam sample spacing, in cells
    contact_radius: float = 0.05  # disc marked occupied around a contact point (m)
    suspect_cleared: float = -0.8  # log-odds at or below which a suspected cell is seen free
    max_clearance: float = 2.0  # clearance saturates here (m); exact below it

    def __post_init__(self) -> None:
        for f in fields(self):
            if not math.isfinite(getattr(self, f.name)):
                raise ValueError(f"world model settings: {f.name} must be finite")
        positive = ("resolution", "log_odds_hit", "sample_step", "max_clearance")
        if any(getattr(self, name) <= 0 for name in positive):
            raise ValueError(f"world model settings: {', '.join(positive)} must be positive")
        if not self.log_odds_free < 0:
            raise ValueError("world model settings: log_odds_free must be negative")
        if not self.log_odds_min < 0 < self.ambiguous_ceiling < self.occupied_threshold:
            raise ValueError(
                "world model settings: need log_odds_min < 0 < ambiguous_ceiling < occupied_threshold"
            )
        if not self.occupied_threshold < self.log_odds_max:
            raise ValueError("world model settings: need occupied_threshold < log_odds_max")
        if not 0 < self.dominant_share < 1:
            raise ValueError("world model settings: dominant_share must lie in (0, 1)")
        margins = (self.clear_sigmas, self.clear_margin, self.explained_sigmas, self.contact_radius)
        if min(*margins, self.unambiguous_arc) < 0:
            raise ValueError(
                "world model settings: margins, radii and unambiguous_arc must be >= 0"
            )
        if self.sample_step > 1:
            raise ValueError("world model settings: sample_step above one cell would skip cells")


class Grid:
    """Cell geometry: cell ``[i, j]`` spans ``origin + ([i, i+1], [j, j+1]) * resolution``.

    The grid covers the bounds; when they are not a whole number of cells the last row and column
    overhang them.
    """

    def __init__(self, bounds: Bounds, resolution: float) -> None:
        self.bounds = bounds
        self.resolution = resolution
        self.origin = (bounds.xmin, bounds.ymin)
        self.nx = max(1, math.ceil((bounds.xmax - bounds.xmin) / resolution - 1e-9))
        self.ny = max(1, math.ceil((bounds.ymax - bounds.ymin) / resolution - 1e-9))
        self.xs = bounds.xmin + (np.arange(self.nx) + 0.5) * resolution  # cell centres
        self.ys = bounds.ymin + (np.arange(self.ny) + 0.5) * resolution

    @property
    def shape(self) -> tuple[int, int]:
        """``(nx, ny)``: cells along x, along y."""
        return (self.nx, self.ny)

    def cell_of(self, x: float, y: float) -> tuple[int, int]:
        """The cell holding a world point (indices may fall outside the grid; see ``inside``)."""
        res = self.resolution
        return (math.floor((x - self.origin[0]) / res), math.floor((y - self.origin[1]) / res))

    def inside(self, i: int, j: int) -> bool:
        """Whether cell ``(i, j)`` is on the grid."""
        return 0 <= i < self.nx and 0 <= j < self.ny

    def centre_of(self, i: int, j: int) -> tuple[float, float]:
        """The world centre of cell ``(i, j)``."""
        res = self.resolution
        return (self.origin[0] + (i + 0.5) * res, self.origin[1] + (j + 0.5) * res)

    def centres(self, flat: Flat) -> Array:
        """World centres ``[N, 2]`` of flat cell indices."""
        i, j = np.divmod(flat, self.ny)
        return np.stack([self.xs[i], self.ys[j]], axis=-1)

    def flat_of(self, points: Array) -> Flat:
        """Flat indices of the cells holding points ``[N, 2]``; points outside the grid dropped."""
        flat, keep = self.locate(points)
        out: Flat = flat[keep]
        return out

    def locate(self, points: Array) -> tuple[Flat, NDArray[np.bool_]]:
        """Flat indices of the cells holding points ``[N, 2]`` and which points lie in the grid."""
        res = self.resolution
        i = np.floor((points[:, 0] - self.origin[0]) / res).astype(np.intp)
        j = np.floor((points[:, 1] - self.origin[1]) / res).astype(np.intp)
        keep = (i >= 0) & (i < self.nx) & (j >= 0) & (j < self.ny)
        flat: Flat = i * self.ny + j
        return flat, keep


def sector_points(obs: RangeObservation, until: float, step: float) -> Array:
    """Sample points ``[N, 2]`` filling the sensor's cone (or ray) from its origin to ``until``."""
    if until <= 0:
        return np.zeros((0, 2))
    rho = np.arange(0.0, until, step)
    dirs = _cone_directions(obs, until, step)
    return (np.asarray(obs.origin) + rho[:, None, None] * dirs[None, :, :]).reshape(-1, 2)


def hit_points(obs: RangeObservation, distance: float, step: float) -> tuple[Array, Array]:
    """Where the hit may be: sample points ``[N, 2]`` across the cone over ``distance`` ± 2σ of
    the sensor's noise, with their Gaussian range likelihoods ``[N]``."""
    n = 2 * math.ceil(2.0 * obs.noise_std / step) + 1
    z = np.linspace(-2.0, 2.0, n) if n > 1 else np.zeros(1)
    rho = np.maximum(distance + obs.noise_std * z, 0.0)
    dirs = _cone_directions(obs, distance, step)
    points = np.asarray(obs.origin) + rho[:, None, None] * dirs[None, :, :]
    weights = np.broadcast_to(np.exp(-0.5 * z * z)[:, None], points.shape[:2])
    return points.reshape(-1, 2), weights.reshape(-1)


def _cone_directions(obs: RangeObservation, reach: float, step: float) -> Array:
    n = 1 if obs.fov == 0 else math.ceil(obs.fov * reach / step) + 1
    angles = (
        obs.angle + np.linspace(-obs.fov / 2, obs.fov / 2, n) if n > 1 else np.array([obs.angle])
    )
    return np.stack([np.cos(angles), np.sin(angles)], axis=-1)


@dataclass
class _Updates:
    """One integration's cell updates, gathered before they are applied (clearing first)."""

    free: list[Flat]
    sure_cells: list[Flat]  # unambiguous hit shares
    sure_gain: list[Array]
    vague_cells: list[Flat]  # ambiguous hit shares (raise at most to the ceiling)
    vague_gain: list[Array]


class SensedLayer:
    """Log-odds occupancy from range readings; ``occupied`` is the thresholded view."""

    def __init__(self, grid: Grid, settings: WorldModelSettings) -> None:
        self.grid = grid
        self.settings = settings
        self.log_odds = np.zeros(grid.shape)
        self.occupied = np.zeros(grid.shape, dtype=bool)

    def integrate(
        self, observations: Iterable[RangeObservation], known_clearance: Array
    ) -> tuple[Flat, Flat]:
        """Apply readings; ``known_clearance`` is the static layer's clearance per cell.

        Returns the flat indices of cells that became occupied and of cells that stopped being so.
        """
        updates = _Updates([], [], [], [], [])
        hits: list[tuple[RangeObservation, Flat, Array]] = []
        for obs in observations:
            if math.isnan(obs.distance):
                continue  # dropout: no information
            arc = self._beam(obs, updates)
            if arc is not None:
                hits.append((obs, *arc))
        flat = self.log_odds.reshape(-1)
        touched = [self._apply_free(flat, updates.free)]
        # Hit shares use the cleared state: evidence goes to arc cells the beams left standing.
        for obs, cells, likelihood in hits:
            self._share_hit(obs, cells, likelihood, known_clearance.reshape(-1), updates)
        touched.append(self._apply_hits(flat, updates))
        return self._threshold(np.unique(np.concatenate(touched)))

    def _beam(self, obs: RangeObservation, updates: _Updates) -> tuple[Flat, Array] | None:
        """Queue the cells the reading clears; return its hit cells and their likelihoods."""
        s, res = self.settings, self.grid.resolution
        step = s.sample_step * res
        distance = min(obs.distance, obs.max_range)
        until = distance - (s.clear_sigmas * obs.noise_std + s.clear_margin)
        free = np.unique(self.grid.flat_of(sector_points(obs, until, step)))
        if not obs.hit:
            updates.free.append(free)
            return None
        points, likelihood = hit_points(obs, distance, step / 2)
        flat, keep = self.grid.locate(points)
        cells, inverse = np.unique(flat[keep], return_inverse=True)
        weights = np.bincount(inverse, weights=likelihood[keep], minlength=cells.size)
        updates.free.append(np.setdiff1d(free, cells, assume_unique=True))
        return (cells, np.asarray(weights, dtype=np.float64)) if cells.size else None

    def _share_hit(
        self,
        obs: RangeObservation,
        cells: Flat,
        likelihood: Array,
        known_clearance: Array,
        updates: _Updates,
    ) -> None:
        """Split one hit's evidence across its cells by range likelihood x occupancy probability.

        A cell is sure of its share only if it holds most of it and the arc is narrow; otherwise
        other cells along a wide arc could have caused the hit just as well (and cells cleared by
        other readings make whichever cell remains look likely, so that alone proves nothing).
        """
        s = self.settings
        tolerance = s.explained_sigmas * obs.noise_std + self.grid.resolution * math.sqrt(0.5)
        explained = known_clearance[cells] <= tolerance
        p = np.where(explained, 1.0, 1.0 / (1.0 + np.exp(-self.log_odds.reshape(-1)[cells])))
        share = likelihood * p / np.sum(likelihood * p)
        narrow = (
            obs.fov * min(obs.distance, obs.max_range) <= s.unambiguous_arc * self.grid.resolution
        )
        sure = ~explained & (share > s.dominant_share) & narrow
        vague = ~explained & ~sure
        updates.sure_cells.append(cells[sure])
        updates.sure_gain.append(s.log_odds_hit * share[sure])
        updates.vague_cells.append(cells[vague])
        updates.vague_gain.append(s.log_odds_hit * share[vague])

    def _apply_free(self, flat: Array, free: list[Flat]) -> Flat:
        if not free:
            return np.zeros(0, dtype=np.intp)
        cells, n = np.unique(np.concatenate(free), return_counts=True)
        s = self.settings
        flat[cells] = np.maximum(flat[cells] + n * s.log_odds_free, s.log_odds_min)
        return cells

    def _apply_hits(self, flat: Array, updates: _Updates) -> Flat:
        s = self.settings
        sure_cells, sure_gain = _summed(updates.sure_cells, updates.sure_gain)
        flat[sure_cells] = np.minimum(flat[sure_cells] + sure_gain, s.log_odds_max)
        vague_cells, vague_gain = _summed(updates.vague_cells, updates.vague_gain)
        now = flat[vague_cells]
        # Ambiguous evidence may lift a cell up to the ceiling, never lower it, never past it.
        flat[vague_cells] = np.maximum(now, np.minimum(now + vague_gain, s.ambiguous_ceiling))
        return np.concatenate([sure_cells, vague_cells])

    def _threshold(self, touched: Flat) -> tuple[Flat, Flat]:
        occupied = self.occupied.reshape(-1)
        before = occupied[touched]
        after = self.log_odds.reshape(-1)[touched] > self.settings.occupied_threshold
        occupied[touched] = after
        return touched[after & ~before], touched[before & ~after]


def _summed(cells: list[Flat], gains: list[Array]) -> tuple[Flat, Array]:
    """Per-cell sums of gains given as parallel lists of (cells, gains)."""
    if not cells:
        return np.zeros(0, dtype=np.intp), np.zeros(0)
    all_cells = np.concatenate(cells)
    unique, inverse = np.unique(all_cells, return_inverse=True)
    sums = np.bincount(inverse, weights=np.concatenate(gains), minlength=unique.size)
    return unique, np.asarray(sums, dtype=np.float64)

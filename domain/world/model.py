"""The robot's world model: costmap layers over the arena, and the two views planners read.

Layers, in the manner of a Nav2 costmap:

- **static**: the arena walls and the obstacles the operator declared known, as exact distances
  from cell centres (not a rasterisation), so a 0.30 m corridor between known walls is 0.30 m
  wide in the model and the 0.15 m robot fits; and the known maps' occupied cells (the
  ``sim.raster.OccupancyRaster`` the simulator collides with), as the clearance to the grid
  cells they cover, as the sensed layer's. A known map's free cells count as observed, its
  unknown cells as never observed.
- **sensed**: log-odds occupancy from the head's range readings (``domain.world.sensed``: ray
  clearing before marking, cone hits shared across the arc, clamped, thresholded).
- **observed**: the cells a beam crossed or the body covered (``domain.world.observed``).
- **contact**: soft evidence where a bumper touched something (``domain.world.contact``).

Two views combine them:

- the **lethal clearance**: metres from each cell centre to the nearest static or sensed
  obstacle (exact for the static layer; the sensed cells' distance transform less half a cell).
  Where the body's footprint comes closer than its radius plus the planning margin, it cannot
  be: the only hard facts, and the only ones that can prove a goal unreachable.
- the **risk**: per cell, log P(free) from the soft layers: the contact evidence and, for
  never-observed cells, the prior of ``unobserved_density``. Soft evidence raises what a motion
  costs; it never makes a cell lethal.

Unknown cells are traversable (the head sees little of the space round the body; a model that
took the unknown for occupied would forbid nearly every motion), but they cost what sweeping
them blind risks. ``version`` counts changes of the lethal view, ``soft_version`` of the risk.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from domain.world.contact import ContactEvidence, touched_side
from domain.world.distance import DistanceMap, clearance_map
from domain.world.grid import Grid, cells_round
from domain.world.interpolate import bilinear
from domain.world.observation import RangeObservation
from domain.world.observed import ObservedLayer, body_cells
from domain.world.sensed import SensedLayer
from domain.world.settings import CostmapSettings
from domain.world.static import distance_block
from sim.obstacles import Obstacle
from sim.raster import FREE, OCCUPIED, OccupancyRaster
from sim.robot import DEFAULT_GEOMETRY, Array, RobotGeometry
from sim.world import Bounds


class WorldModel:
    """Costmap layers over the arena and the lethal and risk views of them."""

    def __init__(
        self,
        bounds: Bounds,
        known: Sequence[Obstacle] = (),
        settings: CostmapSettings = CostmapSettings(),  # noqa: B008 (frozen, shared safely)
        geometry: RobotGeometry = DEFAULT_GEOMETRY,
        maps: Sequence[OccupancyRaster] = (),
    ) -> None:
        self.bounds = bounds
        self.settings = settings
        self.geometry = geometry
        self.grid = Grid(bounds, settings.resolution)
        self.version = 0  # changes of the lethal view (static or sensed occupancy)
        self.soft_version = 0  # changes of the risk view (observed cells, contact evidence)
        self._known: list[Obstacle] = []
        self._maps = tuple(maps)
        self._map_distance = self._maps_distance()
        self._reset_static()
        self._sensed = SensedLayer(self.grid, settings)
        self._sensed_map = DistanceMap(self.grid, settings.max_clearance)
        self._observed = ObservedLayer(self.grid)
        for raster in self._maps:
            free = raster.sample(self.grid.origin, self.grid.resolution, self.grid.shape) == FREE
            self._observed.observe(np.flatnonzero(free).astype(np.intp))
        self._evidence = ContactEvidence(self.grid, settings)
        self._lethal: tuple[int, Array] | None = None
        self._body: tuple[float, ...] | None = None  # where the body's cells were last taken
        self._risk: tuple[Any, Array] | None = None
        self._blocked: tuple[Any, Array] | None = None
        self._continuation: tuple[Any, Array] | None = None
        for obstacle in known:
            self.add_known(obstacle)
        self.version = 0  # counts changes after construction

    # --- sensing ------------------------------------------------------------------------------

    def integrate(self, observations: Iterable[RangeObservation]) -> list[tuple[float, float]]:
        """Range readings into the sensed layer; the cells their beams crossed are observed and
        lose their contact evidence. Returns the world centres of the cells that became
        occupied (NaN readings are dropouts and change nothing)."""
        sensed = self._sensed
        became, ceased = sensed.integrate(observations, self._static)
        self._sensed_map.remove((sensed.occupied,), ceased)
        self._sensed_map.add(sensed.occupied, became)
        if became.size or ceased.size:
            self.version += 1
        seen = sensed.lowered
        observed = self._observed.observe(seen)
        if observed or self._evidence.clear(seen):
            self.soft_version += 1
        if not became.size:
            return []
        return [(float(x), float(y)) for x, y in self.grid.centres(became)]

    def observe_body(
        self, pose: tuple[float, float, float], joints: tuple[float, float, float]
    ) -> None:
        """The body lies at ``pose`` with ``joints``: the cells wholly inside it are free (their
        sensed occupancy and contact evidence go) and observed."""
        last = self._body
        if last is not None and _close(last, (*pose, *joints)):
            return  # (it has not moved: the same cells)
        self._body = (*pose, *joints)
        cells = body_cells(self.grid, pose, joints, self.geometry)
        if not cells.size:
            return
        ceased = self._sensed.free(cells)
        if ceased.size:
            self._sensed_map.remove((self._sensed.occupied,), ceased)
            self.version += 1
        observed = self._observed.observe(cells)
        if observed or self._evidence.clear(cells):
            self.soft_version += 1

    def add_contact(
        self,
        pose: tuple[float, float, float],
        joints: tuple[float, float, float],
        part: int,
        side: str,
        t: float,
    ) -> Array:
        """A bumper on ``side`` of ``part`` fired with the body at ``pose``: evidence along that
        side (``domain.world.contact``). Returns the points the evidence lies at."""
        points = touched_side(pose, joints, part, side, self.settings, self.geometry)
        if self._evidence.add(points, t):
            self.soft_version += 1
        return points

    def advance(self, t: float) -> None:
        """Model time is ``t``: contact evidence fades."""
        if self._evidence.fade(t):
            self.soft_version += 1

    def clear_evidence(self, centre: tuple[float, float], radius: float) -> bool:
        """Forget the contact evidence and the sensed occupancy within ``radius`` of ``centre``
        (a recovery: what sensing finds again there comes back); whether anything went."""
        grid = self.grid
        x, y = centre
        (i0, j0), (i1, j1) = (
            grid.cell_of(x - radius, y - radius),
            grid.cell_of(x + radius, y + radius),
        )
        i0, j0, i1, j1 = max(i0, 0), max(j0, 0), min(i1 + 1, grid.nx), min(j1 + 1, grid.ny)
        if i0 >= i1 or j0 >= j1:
            return False
        near = np.hypot(grid.xs[i0:i1, None] - x, grid.ys[None, j0:j1] - y) <= radius
        ii, jj = np.nonzero(near)
        cells = ((ii + i0) * grid.ny + (jj + j0)).astype(np.intp)
        ceased = self._sensed.free(cells)
        if ceased.size:
            self._sensed_map.remove((self._sensed.occupied,), ceased)
            self.version += 1
        cleared = self._evidence.clear(cells)
        if cleared:
            self.soft_version += 1
        return bool(ceased.size) or cleared

    def add_known(self, obstacle: Obstacle) -> None:
        """Add a known obstacle to the static layer (exact distances within ``max_clearance``)."""
        self._known.append(obstacle)
        block = distance_block(obstacle, self.grid, self.settings.max_clearance)
        if block is None:
            return
        (i0, i1, j0, j1), dist = block
        window = self._known_distance[i0:i1, j0:j1]
        if np.any(dist < window):
            np.minimum(window, dist, out=window)
            np.minimum(self._static[i0:i1, j0:j1], dist, out=self._static[i0:i1, j0:j1])
            self.version += 1

    def remove_known(self, obstacle: Obstacle) -> bool:
        """Remove a known obstacle (compared by value) and rebuild the static layer; ``False``
        if it was not known."""
        if obstacle not in self._known:
            return False
        remaining, version = [o for o in self._known if o != obstacle], self.version
        self._known = []
        self._reset_static()
        for other in remaining:
            self.add_known(other)
        self.version = version + 1  # one change, however many obstacles were re-added
        return True

    @property
    def contact_version(self) -> int:
        """Counts changes of the contact evidence (a touch added, cleared or faded)."""
        return int(self._evidence.version)

    @property
    def known(self) -> tuple[Obstacle, ...]:
        """The known obstacles, in the order they were added."""
        return tuple(self._known)

    # --- views --------------------------------------------------------------------------------

    def lethal_clearance(self) -> Array:
        """Metres from each cell centre to the nearest static or sensed obstacle or wall
        (conservative, saturated at ``max_clearance``); a read-only array kept until
        ``version`` changes."""
        if self._lethal is None or self._lethal[0] != self.version:
            sensed = self._sensed_map.get(self._sensed.occupied)
            grid = np.minimum(self._static, sensed)
            grid.flags.writeable = False
            self._lethal = (self.version, grid)
        return self._lethal[1]

    def clearance_at(self, points: Array) -> Array:
        """The lethal clearance at world points ``[..., 2]``: bilinear between cell centres,
        exact to the walls (negative outside the bounds)."""
        return bilinear(
            self.lethal_clearance(), self.grid, np.asarray(points, dtype=float), self.bounds
        )

    def static_clearance(self) -> Array:
        """The clearance to the walls and known obstacles alone (read only)."""
        view = self._static.view()
        view.flags.writeable = False
        return view

    def static_clearance_at(self, points: Array) -> Array:
        """Clearance to the walls and known obstacles alone (what the operator's map says)."""
        return bilinear(self._static, self.grid, np.asarray(points, dtype=float), self.bounds)

    def risk(
        self,
        near: tuple[float, float] | None = None,
        horizon: float = math.inf,
        beyond: float = 1.0,
        facing: tuple[float, float, float] | None = None,
    ) -> Array:
        """Per cell, log P(free) of what the body may touch there unseen (<= 0): the contact
        evidence; for never-observed cells the continuation of sensed obstacles and the prior
        of ``unobserved_density``. With ``near`` (the robot's position), never-observed cells
        farther than ``horizon`` from it keep only ``beyond`` of the prior: what is that far
        will most likely have been looked at by the time the body gets there, and what the
        head then finds in the way is planned round. So do those ahead of the head (``facing``:
        its tip and the heading it looks along), however near: the body reaches them head
        first, after the head's rays have swept them (the cells behind and beside the body are
        what a turn or a tail-first move sweeps unseen). A read-only array kept until the
        layers (or the robot's cell and heading) change."""
        far = near is not None and beyond != 1.0 and math.isfinite(horizon)
        cell = self.cell_of(*near) if far and near is not None else None
        look = None
        if far and facing is not None:  # the tip to a cell, its heading to ~1/64 turn
            look = (self.cell_of(facing[0], facing[1]), round(facing[2] * 32 / math.pi) % 64)
        key = (self.version, self.soft_version, cell, look, horizon, beyond)
        if self._risk is None or self._risk[0] != key:
            whole = np.where(~self._observed.observed, self.settings.unobserved_log_free, 0.0)
            prior = whole
            if far and near is not None:
                prior = whole * beyond
                centre = self.centre_of(*cell) if cell is not None else near
                i, j, distance = cells_round(self.grid.xs, self.grid.ys, centre, horizon)
                keep = distance <= horizon
                if facing is not None:
                    tx, ty, heading = facing
                    ahead = (self.grid.xs[i] - tx) * math.cos(heading) + (
                        self.grid.ys[j] - ty
                    ) * math.sin(heading)
                    keep &= ahead <= 0.0
                prior[i[keep], j[keep]] = whole[i[keep], j[keep]]
            out = self._blocked_grid() + prior
            out.flags.writeable = False
            self._risk = (key, out)
        return self._risk[1]

    def blocked(self) -> Array:
        """Per cell, log P(free) of what a motion may find in its way even when the head looks
        first (<= 0): the contact evidence and the continuation of sensed obstacles into
        never-observed cells. A read-only array kept until either version changes."""
        out = self._blocked_grid()
        view = out.view()
        view.flags.writeable = False
        return view

    def continuation(self) -> Array:
        """Per cell, log P(free) of the continuation of sensed obstacles and of what a bumper
        touched (strong contact evidence), observed or not (what a heuristic may know of it
        without following the observed layer; read only)."""
        key = (self.version, self._evidence.version)
        if self._continuation is None or self._continuation[0] != key:
            distance = self._sensed_map.get(self._sensed.occupied)
            sources = self._sensed.occupied
            if self._evidence.any:
                touched = self._evidence.sources()
                sources = sources | touched
                near = clearance_map(touched, self.grid.resolution, self.settings.max_clearance)
                distance = np.minimum(distance, near)
            if sources.any():
                out = self.settings.continuation_log_free(distance)
                out = np.where(sources, 0.0, out)
            else:
                out = np.zeros(self.grid.shape)
            out.flags.writeable = False
            self._continuation = (key, out)
        return self._continuation[1]

    def _blocked_grid(self) -> Array:
        key = (self.version, self.soft_version, self._evidence.version)
        if self._blocked is None or self._blocked[0] != key:
            out = np.where(self._observed.observed, 0.0, self.continuation())
            if self._evidence.any:
                out = out + self._evidence.log_free()
            self._blocked = (key, out)
        return self._blocked[1]

    # --- layers as arrays ---------------------------------------------------------------------

    def occupied(self) -> NDArray[np.bool_]:
        """Lethal occupancy ``[nx, ny]``: known obstacles within half a cell of the centre and
        sensed cells over the threshold."""
        static = self._known_distance < 0.5 * self.grid.resolution - 1e-9
        out: NDArray[np.bool_] = static | self._sensed.occupied
        return out

    def sensed_occupied(self) -> NDArray[np.bool_]:
        """The sensed layer alone, thresholded (a copy)."""
        return self._sensed.occupied.copy()

    def observed(self) -> NDArray[np.bool_]:
        """The observed layer (a copy)."""
        return self._observed.observed.copy()

    def evidence(self) -> Array:
        """The contact evidence, a probability per cell (a copy)."""
        return self._evidence.probability.copy()

    @property
    def log_odds(self) -> Array:
        """The sensed layer's log-odds (read-only view)."""
        view = self._sensed.log_odds.view()
        view.flags.writeable = False
        return view

    # --- geometry and export ------------------------------------------------------------------

    def cell_of(self, x: float, y: float) -> tuple[int, int]:
        """The cell ``(i, j)`` holding a world point (may lie outside the grid)."""
        return self.grid.cell_of(x, y)

    def centre_of(self, i: int, j: int) -> tuple[float, float]:
        """The world centre of cell ``(i, j)``."""
        return self.grid.centre_of(i, j)

    def recorded_cells(self) -> tuple[NDArray[np.bool_], NDArray[np.intp]]:
        """What ``to_dict`` lists as ``sensed`` (a copy of the occupied mask, flat) and as
        ``contact`` (flat cell indices, sorted)."""
        return self._sensed.occupied.reshape(-1).copy(), self._evidence.cells()

    def cell_centres(self, flat: NDArray[np.intp]) -> list[list[float]]:
        """Cell centres ``[x, y]`` as ``to_dict`` lists them (rounded to 0.1 mm)."""
        return np.round(self.grid.centres(flat), 4).tolist()  # type: ignore[no-any-return]

    def to_dict(self) -> dict[str, Any]:
        """A compact form for the API and viewer: grid geometry, sensed cell centres, contact
        evidence cells (with ``evidence`` their probabilities) and how much was observed."""

        cells = self.cell_centres
        contact = self._evidence.cells()
        p = self._evidence.probability.reshape(-1)[contact]
        return {
            "resolution": self.grid.resolution,
            "origin": [self.grid.origin[0], self.grid.origin[1]],
            "size": [self.grid.nx, self.grid.ny],
            "version": self.version,
            "soft_version": self.soft_version,
            "sensed": cells(np.flatnonzero(self._sensed.occupied)),
            "contact": cells(contact),
            "evidence": [round(float(v), 3) for v in p],
            "observed_fraction": round(self._observed.count / (self.grid.nx * self.grid.ny), 4),
        }

    # --- internals ----------------------------------------------------------------------------

    def _reset_static(self) -> None:
        """The static layer with walls and known maps only."""
        cap = self.settings.max_clearance
        x, y = np.meshgrid(self.grid.xs, self.grid.ys, indexing="ij")
        walls = self.bounds.wall_clearance(np.stack([x, y], axis=-1))
        self._known_distance = self._map_distance.copy()  # to known obstacles and maps only
        self._static = np.minimum(np.clip(walls, 0.0, cap), self._map_distance)

    def _maps_distance(self) -> Array:
        """The clearance of every cell centre to the known maps' occupied cells: the grid
        cells any occupied map cell overlaps, and their distance transform less half a cell
        (``cap`` where no map has any)."""
        cap = self.settings.max_clearance
        grid = self.grid
        covered = np.zeros(grid.shape, dtype=bool)
        for raster in self._maps:
            covered |= raster.cover(grid.origin, grid.resolution, grid.shape, OCCUPIED)
        return clearance_map(covered, grid.resolution, cap)

    @property
    def maps(self) -> tuple[OccupancyRaster, ...]:
        """The known maps of the static layer."""
        return self._maps


def _close(a: tuple[float, ...], b: tuple[float, ...]) -> bool:
    """Whether two (pose, joints) are the same body to a millimetre and a milliradian."""
    return all(abs(x - y) <= 1e-3 for x, y in zip(a, b, strict=True))

"""The robot's sensed world model: an occupancy grid in layers, and clearance queries for planners.

Three layers, in the manner of a Nav2 costmap:

- **static**: the arena walls and the obstacles the operator declared known. Its clearance is
  exact at cell centres (true distances to the obstacles' geometry, not a rasterisation), so a
  0.30 m corridor between known walls is 0.30 m wide in the model and the 0.15 m robot fits.
  ``capsules_clear`` checks known geometry exactly too.
- **sensed**: log-odds occupancy from the head's range readings (``domain.occupancy``: ray
  clearing before marking, cone hits shared across the arc, clamped, thresholded).
- **contact**: discs where a bumper touched something; they persist.

Clearance is the distance to the nearest obstacle surface or wall: exact for the static layer,
from a Euclidean distance transform of the sensed and contact cells (minus half a cell, to stay
conservative) for the rest, combined by minimum and saturated at ``max_clearance``.

**Unknown cells are traversable.** The only range sensors sit on the head, so most of the space
around the body, and all of it behind the robot, is never seen; a pessimistic model (unknown =
occupied) would forbid nearly every motion and every plan through unexplored space. Instead the
model is optimistic: a cell is an obstacle only when a known obstacle, repeated consistent
readings or a contact say so, and the executor replans when new evidence appears on its path.

``version`` increments whenever occupancy in any layer changes (not on every reading), so planners
can cache what they derive from the model.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from domain.clearance import DistanceMap
from domain.grid import unique_cells
from domain.inflated import InflatedGrids
from domain.interpolate import bilinear
from domain.known import axis_samples, distance_block, known_capsules_clear
from domain.marked import MarkedCells
from domain.occupancy import (
    Grid,
    RangeObservation,
    SensedLayer,
    WorldModelSettings,
    range_observations,
)
from sim.obstacles import Obstacle
from sim.robot import Array
from sim.world import Bounds

__all__ = ["RangeObservation", "WorldModel", "WorldModelSettings", "range_observations"]


class WorldModel:
    """Occupancy layers over the arena and clearance queries on them."""

    def __init__(
        self,
        bounds: Bounds,
        known: Sequence[Obstacle] = (),
        settings: WorldModelSettings = WorldModelSettings(),  # noqa: B008 (frozen, shared safely)
    ) -> None:
        self.bounds = bounds
        self.settings = settings
        self.grid = Grid(bounds, settings.resolution)
        self.version = 0
        self._known: list[Obstacle] = []
        self._reset_static()
        self._sensed = SensedLayer(self.grid, settings)
        self._contact = np.zeros(self.grid.shape, dtype=bool)
        self._contact_count = 0
        self._sensed_count = 0  # sensed cells over the threshold
        # Clearance to each dynamic layer, kept current as cells come and go
        # (``domain.clearance``).
        cap = settings.max_clearance
        self._sensed_map = DistanceMap(self.grid, cap)
        self._contact_map = DistanceMap(self.grid, cap)
        self._cache: dict[Any, Any] = {}
        self._cache_version = -1
        # The inflated clearance grids (private: never handed out), kept current window by
        # window (``domain.inflated``), and the cells their suspected tier keeps clear of:
        # contacts, suspected surfaces, the continuation (``domain.marked``), marked afresh
        # once per version where they changed.
        self._grids = InflatedGrids(self.grid)
        self._marked = MarkedCells(self.grid, settings.sensed_continuation, cap)
        self._marked_version = -1
        for obstacle in known:
            self.add_known(obstacle)
        self.version = 0  # counts changes after construction

    # --- layers -------------------------------------------------------------------------------

    def integrate(self, observations: Iterable[RangeObservation]) -> list[tuple[float, float]]:
        """Update the sensed layer with range readings; return the world centres of the cells
        that became occupied (NaN readings are dropouts and change nothing)."""
        sensed = self._sensed
        became, ceased = sensed.integrate(observations, self._static)
        # cells that ceased first (their window transformed afresh, the new cells included),
        # then the new cells' own window
        self._grids.changed(self._sensed_map.remove((sensed.occupied,), ceased))
        self._grids.changed(self._sensed_map.add(sensed.occupied, became))
        self._sensed_count += int(became.size) - int(ceased.size)
        marked = self._marked
        marked.touched(sensed.touched)
        changed = bool(became.size or ceased.size)
        if changed:
            marked.sensed_changed([became, ceased])
        if marked.seen_free(sensed.lowered, sensed.log_odds, self.settings.suspect_cleared):
            changed = True
        if changed:
            self.version += 1
        if not became.size:
            return []
        return [(float(x), float(y)) for x, y in self.grid.centres(became)]

    def add_contact(self, point: tuple[float, float]) -> None:
        """Mark a disc of ``contact_radius`` (at least the cell holding ``point``) occupied for good."""
        x, y = point
        if not (math.isfinite(x) and math.isfinite(y)):
            raise ValueError("contact point: coordinates must be finite")
        r, grid = self.settings.contact_radius, self.grid
        (i0, j0), (i1, j1) = grid.cell_of(x - r, y - r), grid.cell_of(x + r, y + r)
        i0, j0, i1, j1 = max(i0, 0), max(j0, 0), min(i1 + 1, grid.nx), min(j1 + 1, grid.ny)
        if i0 >= i1 or j0 >= j1:
            return  # nowhere near the grid
        disc = np.hypot(grid.xs[i0:i1, None] - x, grid.ys[None, j0:j1] - y) <= r
        i, j = grid.cell_of(x, y)
        if grid.inside(i, j):
            disc[i - i0, j - j0] = True
        window = self._contact[i0:i1, j0:j1]
        new = disc & ~window
        if np.any(new):
            window |= disc
            ii, jj = np.nonzero(new)
            cells = (ii + i0) * grid.ny + (jj + j0)
            self._contact_count += int(cells.size)
            self._grids.changed(self._contact_map.add(self._contact, cells))
            self._marked.flagged(cells)
            self.version += 1

    def add_suspected(self, points: Iterable[tuple[float, float]]) -> None:
        """Mark the cells holding ``points`` as a suspected surface (where a touched one
        probably continues); beams that see them free clear them again."""
        pts = np.asarray([p for p in points if math.isfinite(p[0]) and math.isfinite(p[1])])
        if pts.size == 0:
            return
        flat, inside = self.grid.locate(pts.reshape(-1, 2))
        if self._marked.suspect(unique_cells(flat[inside]), self._contact):
            self.version += 1

    def suspected(self) -> NDArray[np.bool_]:
        """Suspected surfaces: where a touched one probably goes on, and never-observed cells
        near what the range sensors found (a new array)."""
        # the marked cells but contacts are the suspected ones and the continuation
        marked = self._sync_marked().marked
        out: NDArray[np.bool_] = self._marked.suspected | (marked & ~self._contact)
        return out

    def any_suspected(self) -> bool:
        """Whether any cell is suspected (without building the layer)."""
        if self._marked.suspected_count:
            return True
        # marked cells hold every contact cell: any more are suspected (the continuation)
        return self._sync_marked().count > self._contact_count

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
            self._grids.changed((i0, i1, j0, j1))
            self.version += 1

    def remove_known(self, obstacle: Obstacle) -> bool:
        """Remove a known obstacle (compared by value) and rebuild the static layer; ``False``
        if it was not known."""
        if obstacle not in self._known:
            return False
        remaining, version = [o for o in self._known if o != obstacle], self.version
        self._known = []
        self._reset_static()
        self._grids.reset()  # the static layer changed everywhere: rebuilt when next read
        for other in remaining:
            self.add_known(other)
        self.version = version + 1  # one change, however many obstacles were re-added
        return True

    @property
    def known(self) -> tuple[Obstacle, ...]:
        """The known obstacles, in the order they were added."""
        return tuple(self._known)

    def occupied(self) -> NDArray[np.bool_]:
        """Combined occupancy ``[nx, ny]``: known obstacles within half a cell of the centre,
        sensed cells over the threshold, contact discs."""
        static = self._known_distance < 0.5 * self.grid.resolution - 1e-9
        out: NDArray[np.bool_] = static | self._sensed.occupied | self._contact
        return out

    def sensed_occupied(self) -> NDArray[np.bool_]:
        """The sensed layer alone, thresholded (a copy)."""
        return self._sensed.occupied.copy()

    def contact_occupied(self) -> NDArray[np.bool_]:
        """The contact layer alone (a copy)."""
        return self._contact.copy()

    @property
    def log_odds(self) -> Array:
        """The sensed layer's log-odds (read-only view)."""
        view = self._sensed.log_odds.view()
        view.flags.writeable = False
        return view

    # --- clearance ----------------------------------------------------------------------------

    def clearance(self) -> Array:
        """Metres from each cell centre to the nearest obstacle surface or wall (conservative,
        saturated at ``max_clearance``); cached until ``version`` changes (a read-only array)."""
        cached = self._cached("clearance")
        if cached is None:
            cached = self._store("clearance", np.minimum(self._static, self._dynamic()))
        out: Array = cached
        return out

    def inflated_clearance_at(
        self,
        points: Array,
        inflation: float,
        contact_inflation: float | None = None,
        suspected: bool = False,
    ) -> Array:
        """Clearance with sensed cells grown by ``inflation`` metres and contact cells by
        ``contact_inflation`` (default: the same); known obstacles and walls exact. The head
        sees only part of a hidden obstacle, and a bumper only the point it pressed: the rest
        lies beyond. With ``suspected``, suspected-surface cells count as contact cells."""
        grid = self.inflated_grid(inflation, contact_inflation, suspected)
        return bilinear(grid, self.grid, np.asarray(points, dtype=float), self.bounds)

    def inflated_grid(
        self, inflation: float, contact_inflation: float | None = None, suspected: bool = False
    ) -> Array:
        """The grid ``inflated_clearance_at`` interpolates (read only; compiled planners read
        it directly): one per inflation and tier, brought up to date only where the layers
        (with ``suspected``, the marked cells: ``domain.marked``) changed since it was read."""
        grow_contact = inflation if contact_inflation is None else contact_inflation
        if suspected and self.any_suspected():
            near = self._sync_marked().clearance()
        else:
            suspected, near = False, self._contact_map.get(self._contact)
        sensed = self._sensed_map.get(self._sensed.occupied)
        grid: Array = self._grids.get(
            (inflation, grow_contact, suspected), self._static, sensed, near
        )
        return grid

    def _sync_marked(self) -> MarkedCells:
        """The suspected tier's marked cells, marked afresh once per version of the model
        where they may have changed (the inflated grids of the tier told where their
        clearance did)."""
        marked = self._marked
        if self._marked_version != self.version:
            self._marked_version = self.version
            sensed = self._sensed_map.get(self._sensed.occupied)
            args = (self._contact, sensed, self._sensed.log_odds, self._sensed_count > 0)
            for window in marked.sync(*args):
                self._grids.changed(window, suspected_only=True)
        return marked

    def clearance_at(self, points: Array) -> Array:
        """Clearance at world points ``[..., 2]``: bilinear between cell centres, exact to the
        walls (negative outside the bounds). Between centres, near a convex obstacle, bilinear
        may exceed the true distance by about resolution² / (8 x distance); ``capsules_clear``
        measures known obstacles exactly instead."""
        return bilinear(self.clearance(), self.grid, np.asarray(points, dtype=float), self.bounds)

    def static_clearance_at(self, points: Array) -> Array:
        """Clearance to the walls and known obstacles alone (what the operator's map says)."""
        return bilinear(self._static, self.grid, np.asarray(points, dtype=float), self.bounds)

    @property
    def static_version(self) -> int:
        """Changes when a known obstacle is added."""
        return len(self.known)

    def capsules_clear(
        self, starts: Array, ends: Array, radii: Array, margin: float = 0.0
    ) -> NDArray[np.bool_]:
        """Whether every capsule keeps ``margin`` clear, per leading index of ``starts`` and
        ``ends`` ``[..., C, 2]`` (radii ``[C]``). Walls and known obstacles are checked exactly;
        sensed and contact cells by clearance samples every half cell along each axis. Radius +
        margin must stay below ``max_clearance`` (clearance saturates there)."""
        a, b = np.asarray(starts, dtype=float), np.asarray(ends, dtype=float)
        lead = a.shape[:-2]
        a, b = a.reshape(-1, *a.shape[-2:]), b.reshape(-1, *b.shape[-2:])  # [B, C, 2]
        need = np.asarray(radii, dtype=float) + margin  # [C]
        if np.any(need >= self.settings.max_clearance):
            raise ValueError("capsules_clear: radius + margin must stay below max_clearance")
        walls = np.minimum(self.bounds.wall_clearance(a), self.bounds.wall_clearance(b))
        ok: NDArray[np.bool_] = np.all(walls >= need, axis=-1)  # wall distance is linear: ends
        points = axis_samples(a, b, 0.5 * self.grid.resolution)  # [B, C, n, 2]
        if self._known:
            near_known = bilinear(self._static, self.grid, points).min(axis=-1)  # [B, C]
            known_capsules_clear(self._known, a, b, near_known, need, self.grid.resolution, ok)
        if self._has_dynamic():
            dynamic = bilinear(self._dynamic(), self.grid, points)
            ok &= np.all(dynamic >= need[:, None], axis=(-2, -1))
        return ok.reshape(lead)

    def component_labels(self, min_clearance: float) -> NDArray[np.int32]:
        """Connected regions (4-connectivity, 1..n; 0 = too tight) of cells whose clearance is at
        least ``min_clearance`` (at most ``max_clearance``); cached per threshold until ``version``
        changes."""
        key = f"labels:{min_clearance!r}"
        cached = self._cached(key)
        if cached is None:
            labels, _ = ndimage.label(self.clearance() >= min_clearance)
            cached = self._store(key, labels.astype(np.int32))
        out: NDArray[np.int32] = cached
        return out

    def connected(
        self, a: tuple[float, float], b: tuple[float, float], min_clearance: float
    ) -> bool:
        """Whether cells of clearance >= ``min_clearance`` join the cells holding ``a`` and ``b``."""
        ia, ib = self.grid.cell_of(*a), self.grid.cell_of(*b)
        if not (self.grid.inside(*ia) and self.grid.inside(*ib)):
            return False
        labels = self.component_labels(min_clearance)
        return bool(labels[ia] != 0 and labels[ia] == labels[ib])

    # --- geometry and export ------------------------------------------------------------------

    def cell_of(self, x: float, y: float) -> tuple[int, int]:
        """The cell ``(i, j)`` holding a world point (may lie outside the grid)."""
        return self.grid.cell_of(x, y)

    def centre_of(self, i: int, j: int) -> tuple[float, float]:
        """The world centre of cell ``(i, j)``."""
        return self.grid.centre_of(i, j)

    def to_dict(self) -> dict[str, Any]:
        """A compact form for the API and viewer: grid geometry, sensed and contact cell centres."""

        def cells(mask: NDArray[np.bool_]) -> list[list[float]]:
            centres = self.grid.centres(np.flatnonzero(mask))
            return np.round(centres, 4).tolist()  # type: ignore[no-any-return]

        return {
            "resolution": self.grid.resolution,
            "origin": [self.grid.origin[0], self.grid.origin[1]],
            "size": [self.grid.nx, self.grid.ny],
            "version": self.version,
            "sensed": cells(self._sensed.occupied),
            "contact": cells(self._contact),
            "suspected": cells(self.suspected()),
        }

    # --- internals ----------------------------------------------------------------------------

    def _reset_static(self) -> None:
        """The static layer with walls only."""
        cap = self.settings.max_clearance
        x, y = np.meshgrid(self.grid.xs, self.grid.ys, indexing="ij")
        walls = self.bounds.wall_clearance(np.stack([x, y], axis=-1))
        self._known_distance = np.full(self.grid.shape, cap)  # to known obstacles only
        self._static = np.clip(walls, 0.0, cap)  # walls and known obstacles

    def _has_dynamic(self) -> bool:
        return bool(np.any(self._sensed.occupied) or np.any(self._contact))

    def _dynamic(self) -> Array:
        """Clearance to sensed and contact cells: distance between centres minus half a cell
        (cached until ``version`` changes)."""
        cached = self._cached("dynamic")
        if cached is None:
            # The distance to a union of cells is the smaller of the distances to its parts.
            sensed = self._sensed_map.get(self._sensed.occupied)
            contact = self._contact_map.get(self._contact)
            cached = self._store("dynamic", np.minimum(sensed, contact))
        out: Array = cached
        return out

    def _cached(self, key: Any) -> Any:
        if self._cache_version != self.version:
            self._cache.clear()
            self._cache_version = self.version
        return self._cache.get(key)

    def _store(self, key: Any, value: Any) -> Any:
        value.flags.writeable = False  # shared with callers until the next change
        self._cache[key] = value
        return value

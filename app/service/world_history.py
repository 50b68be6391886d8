"""The sensed world model over a mission's model time, as the changes between its versions.

A replay shows the world model as it was at the slider's time, not as it ended: the worker
records, at most once per model second and only when the model changed, which sensed and
contact cells came and went since the previous record (the cell centres of
``WorldModel.to_dict``, the same the API's ``/world`` lists). A mission's history is a few
hundred small changes; it is sent with the trajectory at the end and stored beside it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

RECORD_SECONDS = 1.0  # model seconds between records at most: the replay's resolution
LAYERS = {"sensed": "sensed", "contacts": "contact"}  # change key -> to_dict key

Cell = tuple[float, float]


class WorldView(Protocol):
    """What the history reads of a world model: versions that change with the layers it
    records (``version``: the sensed cells, ``contact_version``: the contact evidence;
    optional), and its cells as ``to_dict`` lists them."""

    def to_dict(self) -> dict[str, Any]: ...


class CellView(WorldView, Protocol):
    """A world model that also gives its recorded cells as arrays (``recorded_cells``: the
    sensed layer's occupied mask, flat, and the contact cells' flat indices, sorted) and the
    centres of flat cells as ``to_dict`` lists them (``cell_centres``): the history then
    compares masks and turns only the cells that came or went into centres."""

    def recorded_cells(self) -> tuple[NDArray[np.bool_], NDArray[np.intp]]: ...

    def cell_centres(self, flat: NDArray[np.intp]) -> list[list[float]]: ...


@dataclass
class WorldHistory:
    """Changes of the sensed and contact cells, each ``{"t", "sensed": {"added", "removed"},
    "contacts": {"added", "removed"}}`` with cell centres ``[x, y]`` in metres."""

    every: float = RECORD_SECONDS
    changes: list[dict[str, Any]] = field(default_factory=list)
    _cells: dict[str, set[Cell]] = field(default_factory=lambda: {k: set() for k in LAYERS})
    _mask: NDArray[np.bool_] | None = None  # (a CellView's) occupied mask at the last record
    _contact: NDArray[np.intp] = field(default_factory=lambda: np.zeros(0, dtype=np.intp))
    _version: object = None
    _t: float = float("-inf")

    def observe(self, t: float, world: WorldView) -> None:
        """Record the model at model time ``t`` if it changed and ``every`` has passed."""
        if t - self._t < self.every:  # (first: this runs at every control tick)
            return
        version = versions(world)
        if version is not None and version == self._version:
            return
        self.record(t, world)

    def record(self, t: float, world: WorldView) -> None:
        """Record the model at model time ``t`` now (a change only if cells came or went)."""
        self._t, self._version = t, versions(world)
        change: dict[str, Any] = {"t": round(t, 3)}
        if hasattr(world, "recorded_cells") and hasattr(world, "cell_centres"):
            self._record_cells(world, change)  # type: ignore[arg-type]
            if len(change) > 1:
                self.changes.append(change)
            return
        listed = world.to_dict()
        for key, source in LAYERS.items():
            now = {(float(x), float(y)) for x, y in listed.get(source) or []}
            before = self._cells[key]
            added, removed = sorted(now - before), sorted(before - now)
            if added or removed:
                change[key] = {
                    "added": [list(c) for c in added],
                    "removed": [list(c) for c in removed],
                }
            self._cells[key] = now
        if len(change) > 1:
            self.changes.append(change)

    def _record_cells(self, world: CellView, change: dict[str, Any]) -> None:
        """``record``'s changes by cell index (the same lists: flat order is the centres'
        (x, y) order)."""
        mask, contact = world.recorded_cells()
        before = self._mask if self._mask is not None else np.zeros_like(mask)
        moved = np.flatnonzero(mask != before)
        if moved.size:
            came = mask[moved]
            change["sensed"] = {
                "added": world.cell_centres(moved[came]),
                "removed": world.cell_centres(moved[~came]),
            }
        self._mask = mask
        if contact.size or self._contact.size:
            added = np.setdiff1d(contact, self._contact, assume_unique=True)
            removed = np.setdiff1d(self._contact, contact, assume_unique=True)
            if added.size or removed.size:
                change["contacts"] = {
                    "added": world.cell_centres(added),
                    "removed": world.cell_centres(removed),
                }
        self._contact = contact


def versions(world: WorldView) -> object:
    """What changes whenever a recorded layer does (None: the model keeps no versions; every
    record then reads it). Not the observed cells': they grow at nearly every tick, and
    reading the whole model for them found no change to record."""
    kept = tuple(getattr(world, name, None) for name in ("version", "contact_version"))
    return None if kept == (None, None) else kept


def world_at(changes: list[dict[str, Any]], t: float) -> dict[str, list[list[float]]]:
    """The sensed and contact cells at model time ``t``: every change up to ``t`` applied."""
    cells: dict[str, dict[Cell, None]] = {k: {} for k in LAYERS}  # ordered sets
    for change in changes:
        if float(change["t"]) > t:
            break
        for key in LAYERS:
            layer = change.get(key)
            if layer is None:
                continue
            for x, y in layer.get("removed", []):
                cells[key].pop((x, y), None)
            for x, y in layer.get("added", []):
                cells[key][(x, y)] = None
    return {key: [[x, y] for x, y in found] for key, found in cells.items()}

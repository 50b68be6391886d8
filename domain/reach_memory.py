"""The reachability answers a planner keeps between replans: the latest world's per body shape
and kind of clearance, from which the next world's are carried over, within a count and a byte
budget."""

from __future__ import annotations

from collections.abc import Callable, Hashable
from typing import Any

from domain.lattice import LatticeGrid, MotionTable, body_key
from domain.lattice_reach import Reachability
from sim.robot import Array

REACH_KEPT = 8  # reachability answers kept (the latest per shape and clearance family) ...
REACH_BYTES = 512 << 20  # ... within this many bytes of components (a label and a flag per
# configuration: 13 MB on a 10 m arena, 205 MB on a 40 m one), the least recently used first


class ReachMemory:
    """The latest world version's ``Reachability`` per shape and family; the next version's is
    updated from it (``Reachability(previous=)``). The least recently used go past
    ``REACH_KEPT`` answers or ``REACH_BYTES`` of components."""

    def __init__(self, grid: LatticeGrid, margin: float) -> None:
        self.grid, self.margin = grid, margin
        self._kept: dict[tuple[Any, ...], tuple[Any, Reachability]] = {}

    def __len__(self) -> int:
        return len(self._kept)

    def families(self) -> list[Hashable]:
        """The families kept, the least recently used first."""
        return [key[2] for key in self._kept]

    def held_bytes(self) -> int:
        """Bytes of components the kept answers hold."""
        return sum(r.held_bytes() for _, r in self._kept.values())

    def get(
        self,
        table: MotionTable,
        at_centres: Callable[[], Array],
        version: Any,
        family: Hashable = None,
    ) -> Reachability:
        """The answers for ``table``'s shape at this world ``version`` of ``family``
        (``at_centres``: the clearance at the cell centres, asked only for a new version)."""
        key = (*body_key(table), family)
        latest = self._kept.pop(key, None)
        if latest is None or latest[0] != version:
            if latest is None and len(self._kept) >= REACH_KEPT:  # the least recently used
                del self._kept[next(iter(self._kept))]
            earlier = latest[1] if latest is not None else None
            made = Reachability(self.grid, table, at_centres(), self.margin, earlier)
            latest = (version, made)
        self._kept[key] = latest  # (the newest last)
        held = self.held_bytes()
        while held > REACH_BYTES and len(self._kept) > 1:
            held -= self._kept.pop(next(iter(self._kept)))[1].held_bytes()
        return latest[1]

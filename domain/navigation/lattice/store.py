"""A hash table of state number -> int in plain arrays, for the compiled lattice search.

The compiled search keeps the best node of each state it met, and the motion cache the row of
each evaluated state's motions between replans. numba's typed dict would
do, but building its first one compiles its machinery in every process (~0.3 s, not cached on
disk); this table is two arrays (open addressing, linear probing) that the search reads and
writes in its loop, grown from Python (``room``) when the search asks for it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from domain.kernels import jit

EMPTY = np.iinfo(np.int64).min  # a free slot (keys are state numbers and their negatives)
MAX_LOAD = 0.5  # slots in use at most, as a share of all
FIRST_SLOTS = 1024
_MIX = -7046029254386353131  # 0x9E3779B97F4A7C15 as int64: Fibonacci hashing


class Store:
    """State number -> int64 (``keys``, ``values``: the slots; ``size``: ``[entries]``)."""

    def __init__(self, slots: int = FIRST_SLOTS) -> None:
        if slots < 2 or slots & (slots - 1):
            raise ValueError("slots: a power of two, at least 2")
        self.keys = np.full(slots, EMPTY, dtype=np.int64)
        self.values = np.zeros(slots, dtype=np.int64)
        self.size = np.zeros(1, dtype=np.int64)

    def __len__(self) -> int:
        return int(self.size[0])

    def full(self, more: int) -> bool:
        """Whether adding ``more`` entries would load it past ``MAX_LOAD``."""
        return bool(self.size[0] + more > MAX_LOAD * len(self.keys))

    def room(self, more: int) -> None:
        """Grow (rehash into twice the slots, as often as needed) to take ``more`` entries."""
        slots = len(self.keys)
        while self.size[0] + more > MAX_LOAD * slots:
            slots *= 2
        if slots == len(self.keys):
            return
        keys, values = np.full(slots, EMPTY, dtype=np.int64), np.zeros(slots, dtype=np.int64)
        _rehash(self.keys, self.values, keys, values)
        self.keys, self.values = keys, values

    def get(self, key: int, default: int | None = None) -> int | None:
        """The value of ``key`` (``default`` if absent)."""
        at = int(slot(self.keys, key))
        return int(self.values[at]) if self.keys[at] == key else default

    def numbers(self) -> NDArray[np.int64]:
        """The keys it holds."""
        out: NDArray[np.int64] = self.keys[self.keys != EMPTY]
        return out

    def forget_near(self, near: NDArray[np.bool_], i0: int, j0: int, plane: int, ny: int) -> None:
        """Forget the states whose cell ``(i, j)`` lies where ``near`` (a window of cells
        whose first is ``(i0, j0)``) holds."""
        keys, values = self.keys.copy(), self.values.copy()
        self.keys.fill(EMPTY)
        self.size[0] = 0
        _keep_far(keys, values, np.ascontiguousarray(near), i0, j0, plane, ny, self.keys,
                  self.values, self.size)  # fmt: skip


@jit
def slot(keys: NDArray[np.int64], key: int) -> int:  # pragma: no cover - compiled
    """Where ``key`` is, or the free slot where it would go."""
    mask = keys.shape[0] - 1
    at = ((key * _MIX) >> 32) & mask
    while keys[at] != EMPTY and keys[at] != key:
        at = (at + 1) & mask
    return int(at)


@jit
def put(  # pragma: no cover - compiled
    keys: NDArray[np.int64], values: NDArray[np.int64], size: NDArray[np.int64], key: int,
    value: int,
) -> None:  # fmt: skip
    """Set ``key`` to ``value`` (the caller keeps room: ``Store.room``)."""
    at = slot(keys, key)
    if keys[at] == EMPTY:
        keys[at] = key
        size[0] += 1
    values[at] = value


@jit
def _rehash(  # pragma: no cover - compiled
    old_keys: NDArray[np.int64], old_values: NDArray[np.int64], keys: NDArray[np.int64],
    values: NDArray[np.int64],
) -> None:  # fmt: skip
    for q in range(old_keys.shape[0]):
        if old_keys[q] != EMPTY:
            at = slot(keys, old_keys[q])
            keys[at], values[at] = old_keys[q], old_values[q]


@jit
def _keep_far(  # pragma: no cover - compiled
    old_keys: NDArray[np.int64], old_values: NDArray[np.int64], near: NDArray[np.bool_],
    i0: int, j0: int, plane: int, ny: int, keys: NDArray[np.int64], values: NDArray[np.int64],
    size: NDArray[np.int64],
) -> None:  # fmt: skip
    for q in range(old_keys.shape[0]):
        number = old_keys[q]
        if number == EMPTY:
            continue
        cell = number % plane
        li, lj = cell // ny - i0, cell % ny - j0
        if 0 <= li < near.shape[0] and 0 <= lj < near.shape[1] and near[li, lj]:
            continue
        put(keys, values, size, number, old_values[q])

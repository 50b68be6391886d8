"""The compiled search's store of per-state numbers (a numba typed dict) and its bulk edits.

The motion cache keeps the free motions of the states searched (a bitmask each) between
replans; the compiled search reads and adds to them in its loop. Reading the keys or dropping
many from Python one at a time costs microseconds each, so both are compiled too.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from domain.occupancy_kernel import _jit

try:
    from numba import types
    from numba.typed import Dict
except ImportError:  # pragma: no cover - without numba the search is pyperplan's
    Dict = None


def new_store() -> Any:
    """An empty store of state number -> int (``None`` without numba)."""
    if Dict is None:  # pragma: no cover
        return None
    return Dict.empty(key_type=types.int64, value_type=types.int64)


def store_size(store: Any) -> int:
    """How many states a store holds (0 for none); compiled: ``len`` of a typed dict from
    Python compiles on first use in every process."""
    return 0 if store is None else int(_size(store))


def store_keys(store: Any) -> NDArray[np.int64]:
    """The state numbers a store holds."""
    out = np.empty(store_size(store), dtype=np.int64)
    _keys(store, out)
    return out


def store_drop(store: Any, numbers: NDArray[np.int64]) -> None:
    """Forget these state numbers (those it holds)."""
    if numbers.size:
        _drop(store, np.ascontiguousarray(numbers, dtype=np.int64))


@_jit
def _size(store: Any) -> int:  # pragma: no cover - compiled
    return len(store)


@_jit
def _keys(store: Any, out: NDArray[np.int64]) -> None:  # pragma: no cover - compiled
    for n, key in enumerate(store.keys()):
        out[n] = key


@_jit
def _drop(store: Any, numbers: NDArray[np.int64]) -> None:  # pragma: no cover - compiled
    for key in numbers:
        if key in store:
            del store[key]

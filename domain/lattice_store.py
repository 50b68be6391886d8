"""The compiled search's store of per-state numbers (a numba typed dict) and its bulk edits.

The motion cache keeps the free motions of the states searched (a bitmask each) between
replans; the compiled search reads and adds to them in its loop. Forgetting the states near a
change is compiled too: from Python a typed dict costs microseconds per key (and compiles its
methods on first use in every process).
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


def store_forget(store: Any, near: NDArray[np.bool_], i0: int, j0: int, plane: int, ny: int) -> int:
    """Forget the states whose cell ``(i, j)`` lies where ``near`` (a window of cells whose
    first is ``(i0, j0)``) holds; how many states the store keeps."""
    return int(_forget(store, np.ascontiguousarray(near), i0, j0, plane, ny))


@_jit
def _forget(  # pragma: no cover - compiled
    store: Any, near: NDArray[np.bool_], i0: int, j0: int, plane: int, ny: int
) -> int:
    drop = np.empty(len(store), dtype=np.int64)
    n = 0
    for number in store:
        cell = number % plane
        li, lj = cell // ny - i0, cell % ny - j0
        if 0 <= li < near.shape[0] and 0 <= lj < near.shape[1] and near[li, lj]:
            drop[n] = number
            n += 1
    for q in range(n):
        del store[drop[q]]
    return len(store)

"""The one compile switch of ``domain``'s numba kernels: ``jit`` and whether it compiles.

Every compiled path of ``domain`` (the sensed layer, distance maps, interpolation, the lattice
search, the feasibility flood) compiles with ``jit`` and reads ``AVAILABLE``: without numba, or
with ``SCREWSNAKE_KERNELS=numpy``, ``AVAILABLE`` is False and each caller takes its numpy path,
which gives the same numbers (the tests hold each kernel to it).
"""

from __future__ import annotations

from typing import Any

from sim.kernel_setting import kernel_setting

try:  # numba is a dependency, but the numpy path must keep working without it
    import numba
except ImportError:  # pragma: no cover - exercised by installs without numba
    numba = None  # type: ignore[assignment]

AVAILABLE = numba is not None and kernel_setting() != "numpy"


def jit(fn: Any) -> Any:
    """Compile ``fn`` with numba (cached on disk, no GIL held) when it is available, else leave
    it Python."""
    if numba is None:  # pragma: no cover
        return fn
    return numba.njit(cache=True, nogil=True)(fn)

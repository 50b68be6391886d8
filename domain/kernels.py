"""The one compile switch of ``domain``'s numba kernels: ``jit``, whether it compiles, and where.

Every compiled path of ``domain`` (the sensed layer, distance maps, interpolation, the lattice
search, the feasibility flood) compiles with ``jit`` and reads ``AVAILABLE``: without numba, or
with ``SCREWSNAKE_KERNELS=numpy``, ``AVAILABLE`` is False and each caller takes its numpy path,
which gives the same numbers (the tests hold each kernel to it).

Compiled code is cached on disk, per version of ``domain``'s sources: numba keys a function's
cache by its own file only, so a kernel that inlines one from another module (the search calls
the cost evaluation) would keep running the callee it was first compiled with after that
callee changed. One cache directory per digest of the package's sources cannot go stale.
"""

from __future__ import annotations

import hashlib
import os
import shutil
from pathlib import Path
from typing import Any

from sim.kernel_setting import kernel_setting

try:  # numba is a dependency, but the numpy path must keep working without it
    import numba
except ImportError:  # pragma: no cover - exercised by installs without numba
    numba = None  # type: ignore[assignment]

AVAILABLE = numba is not None and kernel_setting() != "numpy"

_ROOT = Path(__file__).resolve().parent


def sources_digest() -> str:
    """A digest of every source file of ``domain`` (what its compiled code depends on)."""
    digest = hashlib.sha256()
    for path in sorted(_ROOT.rglob("*.py")):
        digest.update(path.relative_to(_ROOT).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def _use_versioned_cache() -> None:
    """Point numba's disk cache at a directory of this version of the sources (and remove the
    directories of other versions), unless the user chose one (``NUMBA_CACHE_DIR``)."""
    if numba is None or os.environ.get("NUMBA_CACHE_DIR"):
        return
    base = _ROOT / "__pycache__"
    here = base / f"numba-{sources_digest()}"
    try:
        here.mkdir(parents=True, exist_ok=True)
        for other in base.glob("numba-*"):
            if other != here:
                shutil.rmtree(other, ignore_errors=True)
    except OSError:  # a read-only install: numba then finds its own place
        return
    numba.config.CACHE_DIR = str(here)  # type: ignore[attr-defined]


_use_versioned_cache()


def jit(fn: Any) -> Any:
    """Compile ``fn`` with numba (cached on disk, no GIL held) when it is available, else leave
    it Python."""
    if numba is None:  # pragma: no cover
        return fn
    return numba.njit(cache=True, nogil=True)(fn)

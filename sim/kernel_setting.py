"""The one setting that chooses compiled (numba) or numpy kernels, for every compiled path."""

from __future__ import annotations

import os
from typing import Literal

Kernel = Literal["auto", "numba", "numpy"]
KERNELS: tuple[Kernel, ...] = ("auto", "numba", "numpy")
KERNEL_SETTING = "SCREWSNAKE_KERNELS"


def kernel_setting() -> Kernel:
    """The kernel chosen by ``SCREWSNAKE_KERNELS`` (``auto`` when unset): ``numba``
    (compiled), ``numpy``, or ``auto`` (numba when it imports)."""
    value = os.environ.get(KERNEL_SETTING, "auto").strip().lower() or "auto"
    if value not in KERNELS:
        raise ValueError(f"{KERNEL_SETTING}: must be one of {KERNELS}, got {value!r}")
    return value

"""The suite's one-time set-up: the compiled kernels built once, before any test runs.

numba compiles on first use and caches on disk. Under pytest-xdist every worker (and every
process its tests start: servers, pool workers, the CLI) would otherwise compile the same
kernels at the same moment, for a minute, while its first missions hit their wall-clock
planning limits. The controller runs the service's own warm-up first; the workers load the
cache.
"""

from __future__ import annotations

import pytest


def pytest_configure(config: pytest.Config) -> None:
    if hasattr(config, "workerinput"):  # an xdist worker: the controller built the cache
        return
    from app.executor.warm import warm_up
    from primitives.library import load_bundled

    warm_up(load_bundled())

"""Per-request timings: named spans of the request being served, for its ``Server-Timing`` header.

The API's timing middleware (``app.api.server_timing``) opens a ``Timings`` for each request
in a context variable; code anywhere below it (the route, the store, the supervisor) adds spans
with ``span(name)``. FastAPI runs sync routes in a thread with a copy of the request's context,
so spans from there land in the same ``Timings``. Outside a request (mission threads, the CLI)
``span`` only costs a context-variable look-up.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar

MAX_SPANS = 32  # spans kept per request (a loop of spans must not grow a header without end)


class Timings:
    """The spans of one request, in wall milliseconds, in the order they ended."""

    def __init__(self) -> None:
        self.started = self.lapped = time.perf_counter()
        self.spans: list[tuple[str, float]] = []

    def add(self, name: str, ms: float) -> None:
        if len(self.spans) < MAX_SPANS:
            self.spans.append((name, ms))

    def since_start(self) -> float:
        """Milliseconds since the request arrived."""
        return (time.perf_counter() - self.started) * 1e3


current: ContextVar[Timings | None] = ContextVar("screwsnake_timings", default=None)


@contextmanager
def span(name: str) -> Iterator[None]:
    """Time the block as span ``name`` of the current request (nothing outside a request)."""
    timings = current.get()
    if timings is None:
        yield
        return
    t0 = time.perf_counter()
    try:
        yield
    finally:
        timings.add(name, (time.perf_counter() - t0) * 1e3)


def lap(name: str) -> None:
    """Record ``name`` as the time since the previous lap (the first: since the request
    arrived). Laps split a request into consecutive stages; spans may nest within them."""
    timings = current.get()
    if timings is not None:
        now = time.perf_counter()
        timings.add(name, (now - timings.lapped) * 1e3)
        timings.lapped = now

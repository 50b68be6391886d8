"""Database faults: a 503 problem+json instead of a 500, and readiness that remembers them.

An engine event sees every database error of the process (requests and the supervisor's
threads alike); a connection or I/O failure makes ``/readyz`` answer 503 for ``window``
seconds. Answers name the kind of failure, never the URL or a server path.
"""

from __future__ import annotations

import logging
import math
import time

from fastapi import FastAPI, Request
from fastapi.responses import JSONResponse
from sqlalchemy import Engine, event
from sqlalchemy.engine import ExceptionContext
from sqlalchemy.exc import DataError, DBAPIError, InterfaceError, InternalError, OperationalError
from sqlalchemy.exc import TimeoutError as PoolTimeout

from app.api.errors import problem

log = logging.getLogger("screwsnake.api")
RETRY_AFTER = 5  # seconds a client should wait after a database failure
UNAVAILABLE = (OperationalError, InterfaceError, InternalError, PoolTimeout)


class DbHealth:
    """When the database last failed; unhealthy for ``window`` seconds after that."""

    def __init__(self, window: float = 10.0) -> None:
        self.window = window
        self.last_failure = -math.inf
        self.kind = ""

    def watch(self, engine: Engine) -> None:
        event.listen(engine, "handle_error", self._on_error)

    def _on_error(self, context: ExceptionContext) -> None:
        exc = context.sqlalchemy_exception
        if context.is_disconnect or isinstance(exc, UNAVAILABLE):
            self.failed(exc)

    def failed(self, exc: BaseException | None) -> None:
        self.last_failure = time.monotonic()
        self.kind = type(exc).__name__ if exc is not None else "error"

    @property
    def healthy(self) -> bool:
        return time.monotonic() - self.last_failure > self.window


def install(app: FastAPI, health: DbHealth) -> None:
    """503 for an unavailable database, 422 for a value it refuses; no URL in either."""

    async def _unavailable(_: Request, exc: Exception) -> JSONResponse:
        log.error("database unavailable: %s", type(exc).__name__)
        health.failed(exc)
        response = problem(503, f"database unavailable: it failed ({type(exc).__name__}); retry")
        response.headers["Retry-After"] = str(RETRY_AFTER)
        return response

    async def _refused(_: Request, exc: Exception) -> JSONResponse:
        return problem(422, "the database cannot store a value of this request")

    for kind in UNAVAILABLE:
        app.add_exception_handler(kind, _unavailable)
    app.add_exception_handler(DataError, _refused)
    # Any other driver error is a failure of the database, not of the request.
    app.add_exception_handler(DBAPIError, _unavailable)

"""The request guard, an ASGI middleware that runs before any body is read.

In order: NUL characters in the path or query (422: PostgreSQL rejects them), the API key
policy (401, before the body is read, so an unauthenticated upload costs nothing), the
websocket Origin check (403), and the body size limit (413 from Content-Length, or while the
body streams in). Answers are problem+json from ``app.api.errors``.
"""

from __future__ import annotations

import secrets
from typing import Any, NoReturn
from urllib.parse import unquote, unquote_to_bytes, urlsplit

from fastapi import FastAPI, HTTPException, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from app.api.errors import problem
from app.missions.spec import MissionSpec
from app.service.jobs import JobsFull
from app.service.live import Refused
from app.service.supervisor import QueueFull
from app.service.validation import ValidationUnavailable
from app.settings import Settings
from primitives.library import Library
from primitives.shapes import learned_joints

SAFE_METHODS = frozenset({"GET", "HEAD", "OPTIONS"})
# Computation, not a write: guarded only under SCREWSNAKE_AUTH=all.
UNGUARDED_WRITES = frozenset({"/simulate"})
# Probes, the viewer page and the API docs stay open under SCREWSNAKE_AUTH=all.
OPEN_PATHS = frozenset({"/", "/livez", "/readyz", "/docs", "/docs/oauth2-redirect", "/redoc"})
OPEN_PATHS |= {"/openapi.json"}
MAP_PATHS = frozenset({"/maps", "/maps/"})  # bodies under SCREWSNAKE_MAX_MAP_BODY
BUSY_RETRY_AFTER = 10  # seconds a client should wait when the queue is full


def _header(scope: Scope, name: bytes) -> bytes | None:
    for key, value in scope.get("headers", ()):
        if key == name:
            return bytes(value)
    return None


def needs_key(settings: Settings, scope: Scope) -> bool:
    """Whether this request must carry the API key under the configured policy."""
    if settings.api_key is None:
        return False
    path = scope.get("path", "")
    if settings.auth == "all":
        return path not in OPEN_PATHS
    if scope["type"] == "websocket":
        return False
    return scope.get("method", "GET") not in SAFE_METHODS and path not in UNGUARDED_WRITES


def given_key(scope: Scope) -> bytes | None:
    """The bearer token of ``Authorization`` as its raw bytes; for websockets also ``?token=``
    (browsers cannot set headers on a websocket), percent-decoded to bytes (a UTF-8 key is
    sent as its UTF-8 bytes, escaped). Never raises, whatever the client sent."""
    header = _header(scope, b"authorization")
    if header is not None:
        scheme, _, token = header.partition(b" ")
        return token.strip() if scheme.lower() == b"bearer" else None
    if scope["type"] == "websocket":
        for pair in bytes(scope.get("query_string", b"")).split(b"&"):
            name, _, value = pair.partition(b"=")
            if unquote_to_bytes(name.replace(b"+", b" ")) == b"token":
                return unquote_to_bytes(value.replace(b"+", b" "))
    return None


def key_bytes(key: str) -> bytes:
    """The configured key as bytes: UTF-8, and an environment value that was not UTF-8 as the
    bytes it was (Python decodes the environment with ``surrogateescape``)."""
    return key.encode("utf-8", "surrogateescape")


def key_ok(settings: Settings, scope: Scope) -> bool:
    """Whether the request carries the API key: the one comparison for HTTP (the middleware and
    the ``writer`` dependency) and websockets, of bytes with bytes (``compare_digest`` refuses
    non-ASCII strings, and a header decoded one way and encoded another never matches)."""
    key = settings.api_key
    given = given_key(scope)
    return key is not None and given is not None and secrets.compare_digest(given, key_bytes(key))


def origin_ok(settings: Settings, scope: Scope) -> bool:
    """No Origin (not a browser), an allowed origin, or the server's own (same-origin)."""
    raw = _header(scope, b"origin")
    if raw is None:
        return True
    origin = raw.decode("latin-1").rstrip("/")
    if origin in settings.allowed_origins or "*" in settings.allowed_origins:
        return True
    host = (_header(scope, b"host") or b"").decode("latin-1")
    try:
        netloc = urlsplit(origin).netloc
    except ValueError:  # e.g. "http://[": not an origin anybody serves, never a 500
        return False
    return bool(host) and netloc == host


def body_limit(settings: Settings, scope: Scope) -> int:
    """The body bytes a request may send: maps (``POST /maps``) have their own limit."""
    if scope.get("path", "") in MAP_PATHS:
        return settings.max_map_body
    return settings.max_body


def has_nul(scope: Scope) -> bool:
    query = unquote(scope.get("query_string", b"").decode("latin-1"))
    return "\x00" in scope.get("path", "") or "\x00" in query


class RequestGuard:
    """Reject what must not reach the app: NUL ids, missing keys, foreign origins, big bodies."""

    def __init__(self, app: ASGIApp, settings: Settings) -> None:
        self.app, self.settings = app, settings

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        websocket = scope["type"] == "websocket"
        refusal = self._refusal(scope)
        if refusal is not None:
            status, title, detail, extra = refusal
            if websocket:  # closing before accept: the handshake is refused (HTTP 403)
                await send({"type": "websocket.close", "code": 4000 + status, "reason": title})
                return
            headers = {"WWW-Authenticate": "Bearer"} if status == 401 else {}
            response = problem(status, detail, **extra)
            response.headers.update(headers)
            await response(scope, receive, send)
            return
        if websocket or scope.get("method") in ("GET", "HEAD"):
            await self.app(scope, receive, send)
            return
        await self.app(scope, self._counted(receive, scope), send)

    def _refusal(self, scope: Scope) -> tuple[int, str, str, dict[str, Any]] | None:
        s = self.settings
        if has_nul(scope):
            detail = "path: NUL characters are not allowed in ids or queries"
            return 422, "Invalid request", detail, {"field": "path"}
        if needs_key(s, scope) and not key_ok(s, scope):
            what = "every request" if s.auth == "all" else "writes"
            return 401, "Unauthorized", f"a valid API key is required for {what}", {}
        if scope["type"] == "websocket" and not origin_ok(s, scope):
            return 403, "Forbidden", "this Origin is not allowed", {}
        length = _header(scope, b"content-length")
        limit = body_limit(s, scope)
        if length is not None and (not length.isdigit() or int(length) > limit):
            detail = f"the request body is limited to {limit} bytes"
            return 413, "Request body too large", detail, {}
        return None

    def _counted(self, receive: Receive, scope: Scope) -> Receive:
        """``receive`` that stops a body streaming past the limit (no Content-Length)."""
        limit, seen = body_limit(self.settings, scope), 0

        async def counted() -> Message:
            nonlocal seen
            message = await receive()
            if message["type"] == "http.request":
                seen += len(message.get("body", b""))
                if seen > limit:
                    raise HTTPException(413, f"the request body is limited to {limit} bytes")
            return message

        return counted


def check_mission(spec: MissionSpec, settings: Settings, library: Library) -> None:
    """What depends on the server: at most ``max_goals`` goals (422 naming ``goals``), its
    library has lattice primitives for a named body shape (422 naming ``shape``; a shape given
    by its joints is learned in the mission when it lacks them), and the speed fits its wall-clock
    limit (422 naming ``speed``)."""
    if len(spec.goals) > settings.max_goals:
        invalid(
            "goals",
            f"{len(spec.goals)} goals, at most {settings.max_goals} (SCREWSNAKE_MAX_GOALS)",
        )
    if spec.goals and spec.planner.domain == "navigation":
        shape = spec.shape_name()
        learnable = shape == "custom" or learned_joints(shape) is not None
        if not learnable and shape not in library.lattice_shapes():
            invalid(
                "shape",
                f"the library has no lattice primitives for {shape!r} to plan with; "
                f"shapes it has: {', '.join(library.lattice_shapes())}",
            )
    if spec.speed == 0:
        return  # unpaced: only the wall-clock limit applies, while it runs
    if spec.speed < settings.min_speed:
        invalid("speed", f"0 (as fast as possible) or at least {settings.min_speed:g}")
    if spec.time_limit / spec.speed > settings.wall_limit:
        invalid(
            "speed",
            f"time_limit / speed = {spec.time_limit / spec.speed:g} wall seconds exceeds the "
            f"server's wall-clock limit of {settings.wall_limit:g} s: raise speed or lower "
            "time_limit",
        )


def invalid(field: str, message: str) -> NoReturn:
    """A 422 problem naming ``field``, in the same shape as the request validation errors."""
    raise RequestValidationError(
        [{"loc": ("body", *field.split(".")), "msg": message, "type": "value_error"}]
    )


def install(app: FastAPI) -> None:
    """A full queue (missions or learning jobs) and unavailable validation processes are a 503
    with Retry-After, never a 500; a refused live update is its own problem (404, 409, 422)."""

    def busy(detail: str) -> JSONResponse:
        response = problem(503, detail)
        response.headers["Retry-After"] = str(BUSY_RETRY_AFTER)
        return response

    async def _busy(_: Request, exc: Exception) -> JSONResponse:
        return busy("too many missions are waiting; retry later")

    async def _jobs_busy(_: Request, exc: Exception) -> JSONResponse:
        return busy("too many learning jobs are waiting; retry later")

    async def _no_validation(_: Request, exc: Exception) -> JSONResponse:
        return busy("requests cannot be validated now (the validation processes failed)")

    async def _refused(_: Request, exc: Exception) -> JSONResponse:
        assert isinstance(exc, Refused)
        return problem(exc.status, exc.detail, exc.field)

    app.add_exception_handler(QueueFull, _busy)
    app.add_exception_handler(JobsFull, _jobs_busy)
    app.add_exception_handler(ValidationUnavailable, _no_validation)
    app.add_exception_handler(Refused, _refused)

"""The ``Server-Timing`` header: where the server spent a request's time (W3C Server Timing).

An ASGI middleware, outermost, opens the request's ``app.timing.Timings``; the spans the route
and the store record (e.g. ``validate``, ``lock``, ``write``, ``queue``) go out with the response
as ``Server-Timing: validate;dur=0.4, lock;dur=0.0, ..., total;dur=3.1`` (milliseconds), where
``total`` runs from the request's arrival to the response's first byte. A client (or a bench)
compares it with what it measured itself: the difference is the network and its own waiting.
"""

from __future__ import annotations

from starlette.types import ASGIApp, Message, Receive, Scope, Send

from app.timing import Timings, current


def header(timings: Timings) -> bytes:
    """The header's value: each span, then ``total``."""
    parts = [f"{name};dur={ms:.2f}" for name, ms in timings.spans]
    parts.append(f"total;dur={timings.since_start():.2f}")
    return ", ".join(parts).encode("latin-1")


class ServerTiming:
    """Adds ``Server-Timing`` to every HTTP response (websockets are left alone)."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        timings = Timings()
        token = current.set(timings)

        async def timed_send(message: Message) -> None:
            if message["type"] == "http.response.start":
                headers = list(message.get("headers", ()))
                headers.append((b"server-timing", header(timings)))
                message = {**message, "headers": headers}
            await send(message)

        try:
            await self.app(scope, receive, timed_send)
        finally:
            current.reset(token)

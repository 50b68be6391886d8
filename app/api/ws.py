"""WS /missions/{id}/ws: a snapshot, then state frames and events, always ending with `end`.

The client's messages are read from the moment the socket is accepted, so a client that leaves
while its snapshot waits for the store (a few are read at once) stops waiting: a crowd of clients
opening and closing leaves no backlog in front of the next one.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
from collections.abc import Awaitable
from typing import Any, TypeVar

import orjson
from anyio import to_thread
from fastapi import APIRouter, WebSocket, WebSocketDisconnect
from starlette.websockets import WebSocketState

from app.api.deps import Services
from app.api.missions import plan_of, resource_data
from app.missions.status import TERMINAL
from app.service.frames import EndFrame
from app.store.models import MissionRow

router = APIRouter(tags=["websocket"])
T = TypeVar("T")
MAX_CLIENT_MESSAGE = 4096  # bytes: clients only ever send small control messages
CLOSE_WAIT = 5.0  # seconds the handler lets the reader's own close frame go out before it ends


async def _receive(ws: WebSocket, closed: asyncio.Event, closing: asyncio.Event) -> None:
    """Read what the client sends (ping, malformed, oversized) until it disconnects; an
    oversized message closes the socket (1009), ``closing`` set while that close goes out."""
    try:
        while True:
            message = await ws.receive()
            if message["type"] == "websocket.disconnect":
                break
            data = message.get("text") or (message.get("bytes") or b"").decode("utf-8", "replace")
            if len(data) > MAX_CLIENT_MESSAGE:
                closing.set()
                await ws.close(code=1009, reason="message too big")
                break
            try:
                parsed = json.loads(data)
            except (ValueError, RecursionError):  # not JSON, or nested past the parser's depth
                await ws.send_json({"type": "error", "detail": "messages must be JSON objects"})
                continue
            if isinstance(parsed, dict) and parsed.get("type") == "ping":
                await ws.send_json({"type": "pong"})
            else:
                await ws.send_json(
                    {"type": "error", "detail": 'unknown message; only {"type": "ping"}'}
                )
    except (WebSocketDisconnect, RuntimeError):
        pass
    finally:
        closed.set()


def snapshot(svc: Services, row: MissionRow) -> str:
    """The first frame: the mission and its plan as the store has them now, as the frame's text
    (written in the snapshot's thread: a large mission's is megabytes, which the standard
    library's encoder would write on the event loop in one piece)."""
    frame = {
        "type": "snapshot",
        "mission": resource_data(svc, row),
        "plan": plan_of(svc, row.id).model_dump(mode="json"),
    }
    return orjson.dumps(frame).decode()


def _retrieve(task: asyncio.Task[Any]) -> None:
    """A done callback: an abandoned task's outcome is read (never logged as lost)."""
    if not task.cancelled():
        task.exception()


async def _unless_closed(closed: asyncio.Event, work: Awaitable[T]) -> tuple[bool, T | None]:
    """``(True, result)`` of ``work``, or ``(False, None)`` as soon as the client has gone; the
    work is then cancelled (a store read still waiting for its thread never starts), also when
    this handler itself is cancelled."""
    task = asyncio.ensure_future(work)
    waiter = asyncio.ensure_future(closed.wait())
    try:
        await asyncio.wait({task, waiter}, return_when=asyncio.FIRST_COMPLETED)
    finally:
        waiter.cancel()
        finished = task.done()
        if not finished:
            task.cancel()
            task.add_done_callback(_retrieve)
    if not finished or task.cancelled():
        return False, None
    return True, task.result()


@router.websocket("/missions/{mission_id}/ws")
async def mission_socket(ws: WebSocket, mission_id: str) -> None:
    svc: Services = ws.app.state.services
    await ws.accept()
    closed, closing = asyncio.Event(), asyncio.Event()
    reader = asyncio.create_task(_receive(ws, closed, closing))
    channel = None
    try:
        # The store is read in a thread (a few at once: ``ws_snapshot_threads``): a burst of
        # clients connecting must neither stall the event loop for their database reads nor
        # take every thread from the API's requests.
        read = to_thread.run_sync(svc.store.get_mission, mission_id, limiter=svc.snapshots)
        here, row = await _unless_closed(closed, read)
        if not here:
            return
        if row is None:
            await ws.send_json(
                {"type": "error", "status": 404, "detail": f"mission {mission_id} not found"}
            )
            await ws.close(code=4404)
            return
        channel = svc.hub.subscribe(mission_id)  # before the snapshot: no frame falls between
        made = to_thread.run_sync(snapshot, svc, row, limiter=svc.snapshots)
        here, first = await _unless_closed(closed, made)
        if not here or first is None:
            return
        await ws.send_text(first)
        if row.status in TERMINAL:
            await ws.send_json({"type": "end", "status": row.status, "reason": row.reason})
            return
        while not closed.is_set():
            here, frame = await _unless_closed(closed, channel.next())
            if not here:
                break
            if frame is None:  # fell too far behind: dropped, others unaffected
                svc.metrics.clients_dropped.inc()
                await ws.close(code=1013, reason="client too slow")
                return
            await ws.send_json(frame.model_dump(mode="json"))
            svc.metrics.frames_sent.inc()
            if isinstance(frame, EndFrame):
                return
    except (WebSocketDisconnect, RuntimeError):
        pass
    finally:
        if channel is not None:
            svc.metrics.frames_dropped.inc(channel.dropped)
            svc.hub.unsubscribe(mission_id, channel)
        if closing.is_set() and not reader.done():
            # The reader is sending its close: a frame sent meanwhile found the socket closing
            # and ended this loop. Cancelling the reader now could drop the close frame, and
            # the client would wait for it forever.
            with contextlib.suppress(Exception):
                await asyncio.wait_for(asyncio.shield(reader), CLOSE_WAIT)
        reader.cancel()
        if (
            ws.application_state == WebSocketState.CONNECTED
            and ws.client_state == WebSocketState.CONNECTED
        ):
            with contextlib.suppress(RuntimeError):
                await ws.close()

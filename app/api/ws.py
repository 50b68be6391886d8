"""WS /missions/{id}/ws: a snapshot, then state frames and events, always ending with `end`."""

from __future__ import annotations

import asyncio
import contextlib
import json
from typing import Any

from anyio import to_thread
from fastapi import APIRouter, WebSocket, WebSocketDisconnect
from starlette.websockets import WebSocketState

from app.api.deps import Services
from app.api.missions import plan_of, resource
from app.missions.status import TERMINAL
from app.service.frames import EndFrame
from app.store.models import MissionRow

router = APIRouter(tags=["websocket"])
MAX_CLIENT_MESSAGE = 4096  # bytes: clients only ever send small control messages


async def _receive(ws: WebSocket, closed: asyncio.Event) -> None:
    """Read what the client sends (ping, malformed, oversized) until it disconnects."""
    try:
        while True:
            message = await ws.receive()
            if message["type"] == "websocket.disconnect":
                break
            data = message.get("text") or (message.get("bytes") or b"").decode("utf-8", "replace")
            if len(data) > MAX_CLIENT_MESSAGE:
                await ws.close(code=1009, reason="message too big")
                break
            try:
                parsed = json.loads(data)
            except json.JSONDecodeError:
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


def snapshot(svc: Services, row: MissionRow) -> dict[str, Any]:
    """The first frame: the mission and its plan as the store has them now."""
    return {
        "type": "snapshot",
        "mission": resource(svc, row).model_dump(mode="json"),
        "plan": plan_of(svc, row.id).model_dump(mode="json"),
    }


@router.websocket("/missions/{mission_id}/ws")
async def mission_socket(ws: WebSocket, mission_id: str) -> None:
    svc: Services = ws.app.state.services
    await ws.accept()
    # The store is read in a thread (a few at once: ``ws_snapshot_threads``): a burst of
    # clients connecting must neither stall the event loop for their database reads nor take
    # every thread from the API's requests.
    row = await to_thread.run_sync(svc.store.get_mission, mission_id, limiter=svc.snapshots)
    if row is None:
        await ws.send_json(
            {"type": "error", "status": 404, "detail": f"mission {mission_id} not found"}
        )
        await ws.close(code=4404)
        return
    channel = svc.hub.subscribe(mission_id)  # before the snapshot: no frame falls in between
    closed = asyncio.Event()
    reader = asyncio.create_task(_receive(ws, closed))
    try:
        await ws.send_json(await to_thread.run_sync(snapshot, svc, row, limiter=svc.snapshots))
        if row.status in TERMINAL:
            await ws.send_json({"type": "end", "status": row.status, "reason": row.reason})
            return
        while not closed.is_set():
            getter = asyncio.create_task(channel.next())
            waiter = asyncio.create_task(closed.wait())
            done, _ = await asyncio.wait({getter, waiter}, return_when=asyncio.FIRST_COMPLETED)
            if getter not in done:
                getter.cancel()
                waiter.cancel()
                break
            waiter.cancel()
            frame = getter.result()
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
        svc.metrics.frames_dropped.inc(channel.dropped)
        svc.hub.unsubscribe(mission_id, channel)
        reader.cancel()
        if (
            ws.application_state == WebSocketState.CONNECTED
            and ws.client_state == WebSocketState.CONNECTED
        ):
            with contextlib.suppress(RuntimeError):
                await ws.close()

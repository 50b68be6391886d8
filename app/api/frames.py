"""The websocket protocol of ``/missions/{id}/ws`` and its AsyncAPI document (served at
``/asyncapi.json``), built from the frame models.

A client receives a ``snapshot`` first, then ``state`` frames (latest wins, rate-limited),
``event`` and ``plan`` frames in order, and always an ``end`` last. It may send
``{"type": "ping"}`` (answered by ``pong``); anything else is answered by an ``error`` frame.
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field

from app.api.schemas import MissionOut, PlanOut
from app.service.frames import (
    EVENTS,
    EndFrame,
    ErrorFrame,
    Frame,
    PingFrame,
    PlanFrame,
    PongFrame,
    StateFrame,
)


class SnapshotFrame(Frame):
    """First frame: the mission and its plan as they are when the client connects."""

    type: Literal["snapshot"]
    mission: MissionOut = Field(description="the mission resource, as GET /missions/{id}")
    plan: PlanOut = Field(description="the plan, as GET /missions/{id}/plan")


SERVER_FRAMES: tuple[type[Frame], ...] = (
    SnapshotFrame,
    StateFrame,
    *EVENTS,
    PlanFrame,
    EndFrame,
    ErrorFrame,
    PongFrame,
)


def frame_schemas() -> dict[str, dict[str, Any]]:
    """A JSON Schema per frame type, by model name; shared definitions under components."""
    out: dict[str, dict[str, Any]] = {}
    models: tuple[type[Frame], ...] = (*SERVER_FRAMES, PingFrame)
    for model in models:
        out[model.__name__] = model.model_json_schema(ref_template="#/components/schemas/{model}")
    return out


def asyncapi() -> dict[str, Any]:
    """The AsyncAPI 3.0 document of the websocket protocol."""
    schemas: dict[str, Any] = {}
    messages: dict[str, Any] = {}
    for name, schema in frame_schemas().items():
        schemas.update(schema.pop("$defs", {}))
        schemas[name] = schema
        messages[name] = {
            "name": name,
            "title": name,
            "summary": (schema.get("description") or "").split("\n")[0],
            "contentType": "application/json",
            "payload": {"$ref": f"#/components/schemas/{name}"},
        }
    server_messages = {
        m.__name__: {"$ref": f"#/components/messages/{m.__name__}"} for m in SERVER_FRAMES
    }
    return {
        "asyncapi": "3.0.0",
        "info": {
            "title": "screwsnake mission stream",
            "version": "1",
            "description": __doc__,
        },
        "channels": {
            "mission": {
                "address": "/missions/{mission_id}/ws",
                "parameters": {"mission_id": {"description": "the mission's id"}},
                "messages": {
                    **server_messages,
                    "PingFrame": {"$ref": "#/components/messages/PingFrame"},
                },
            }
        },
        "operations": {
            "receiveFrames": {
                "action": "send",
                "summary": "what the server sends: snapshot, state, event, plan, end",
                "channel": {"$ref": "#/channels/mission"},
                "messages": [
                    {"$ref": f"#/channels/mission/messages/{name}"} for name in server_messages
                ],
            },
            "ping": {
                "action": "receive",
                "summary": "what a client may send: a ping",
                "channel": {"$ref": "#/channels/mission"},
                "messages": [{"$ref": "#/channels/mission/messages/PingFrame"}],
            },
        },
        "components": {"schemas": schemas, "messages": messages},
    }

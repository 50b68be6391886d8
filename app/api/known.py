"""A mission's current goals and known obstacles, each with when and how it came.

Built from what the store already holds: the request as posted, and the goals and events the
worker last saved with the mission's state (``update`` events for live additions and removals).
"""

from __future__ import annotations

from typing import Any

from app.api.schemas import GoalOut, KnownObstacleOut
from app.store.models import MissionRow


def updates(row: MissionRow, kind: str) -> list[dict[str, Any]]:
    """The mission's accepted live updates of one kind (``add_goal`` ...), oldest first."""
    events: list[dict[str, Any]] = (row.state or {}).get("events") or []
    return [e for e in events if e.get("kind") == "update" and e.get("update") == kind]


def current_goals(row: MissionRow, live: list[dict[str, Any]] | None = None) -> list[GoalOut]:
    """The goals by index: those posted, then those added live, with progress as the running
    mission's live account has it (``live``), else as last saved."""
    posted: list[dict[str, Any]] = row.request.get("goals", [])
    saved: list[dict[str, Any]] = (row.state or {}).get("goals") or []
    goals = (
        live
        or saved
        or [{"x": g["x"], "y": g["y"], "tolerance": g.get("tolerance", 0.1)} for g in posted]
    )
    added = {int(e["detail"]["goal"]): float(e["t"]) for e in updates(row, "add_goal")}
    removed = {int(e["detail"]["goal"]): float(e["t"]) for e in updates(row, "remove_goal")}
    out = []
    for index, goal in enumerate(goals):
        added_live = index >= len(posted)
        out.append(
            GoalOut.model_validate(
                goal
                | {
                    "source": "live" if added_live else "request",
                    "added_at": added.get(index, 0.0) if added_live else 0.0,
                    "removed_at": removed.get(index),
                }
            )
        )
    return out


def known_obstacle_data(row: MissionRow) -> list[dict[str, Any]]:
    """The obstacles the world model knows, those posted known, then those added live, as the
    JSON their ``KnownObstacleOut`` models dump to, built from the stored request as it is
    (the request and each update were validated when they came): a mission of 10,000
    obstacles is listed in a few milliseconds, where 10,000 models took ~35 ms of their
    thread's GIL (which the event loop's thread then waited for)."""
    out = [
        {"id": f"request-{i}", "source": "request", "added_at": 0.0, "obstacle": o}
        for i, o in enumerate(row.request.get("obstacles", []))
        if o.get("known", True)
    ]
    for n, event in enumerate(updates(row, "add_obstacle")):
        live = KnownObstacleOut(
            id=f"live-{n}",
            source="live",
            added_at=float(event["t"]),
            obstacle=dict(event["detail"]["obstacle"]),
        )
        out.append(live.model_dump(mode="json"))
    return out

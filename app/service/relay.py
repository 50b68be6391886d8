"""The relay: a worker's messages become store writes, then websocket frames, in that order.

Every transition, plan and replan is written before it is broadcast; a mission's end is written
(with the worker's final state and tree), then its ``end`` frame goes out. Used from the
supervisor's mission threads: frames reach the hub through the event loop.
"""

from __future__ import annotations

import asyncio
import json
import logging
import threading
import time
from collections.abc import Callable
from datetime import UTC, datetime, timedelta
from typing import Any

from pydantic import ValidationError

from app.missions.status import MissionStatus
from app.service.frames import (
    EndFrame,
    PlanFrame,
    ReplanEvent,
    StateFrame,
    StatusEvent,
    parse_frame,
)
from app.service.hub import Frame, Hub
from app.service.library import SharedLibrary
from app.service.messages import (
    Ended,
    Events,
    Learned,
    PlanMade,
    Publish,
    Replanned,
    SaveState,
    TrajectoryDone,
    Transition,
    WorkerMessage,
    frames_of,
)
from app.service.metrics import Metrics
from app.settings import Settings
from app.store.repo import Store
from primitives.library import Primitive

log = logging.getLogger("screwsnake.supervisor")
PRUNE_SECONDS = 3600.0  # wall seconds between retention sweeps


class Relay:
    """Stores, then broadcasts, what workers report; ends missions."""

    def __init__(
        self,
        store: Store,
        hub: Hub,
        settings: Settings,
        metrics: Metrics,
        library: SharedLibrary | None = None,
    ) -> None:
        self.store, self.hub, self.settings, self.metrics = store, hub, settings, metrics
        self.library = library  # where learned shapes are stored (none: they are dropped)
        self.loop: asyncio.AbstractEventLoop | None = None  # set when the service starts
        self.trees: dict[str, dict[str, Any]] = {}  # running mission -> latest tree snapshot
        self.shutting_down = threading.Event()
        self.pruned_at = 0.0  # monotonic time of the last retention sweep
        # Told of every status change stored (the supervisor's live accounts follow them).
        self.on_status: Callable[[str, MissionStatus], None] | None = None

    def publish(self, mission_id: str, frame: Frame) -> None:
        """Hand a frame to the hub (from any thread)."""
        if self.loop is not None and not self.loop.is_closed():
            self.loop.call_soon_threadsafe(self.hub.publish, mission_id, frame)

    def publish_all(self, mission_id: str, frames: list[Frame]) -> None:
        """Hand frames to the hub in order (from any thread): one wake of the event loop."""
        if self.loop is not None and not self.loop.is_closed():
            self.loop.call_soon_threadsafe(self._publish_all, mission_id, frames)

    def _publish_all(self, mission_id: str, frames: list[Frame]) -> None:
        for frame in frames:
            self.hub.publish(mission_id, frame)

    def transition(
        self,
        mission_id: str,
        status: MissionStatus,
        reason: str = "",
        state: dict[str, Any] | None = None,
    ) -> None:
        """Store a status change, then broadcast it (nothing when the store refuses it)."""
        if self.store.transition(mission_id, status, reason, state):  # written before broadcast
            if self.on_status is not None:
                self.on_status(mission_id, status)
            self.publish(
                mission_id, StatusEvent(type="event", kind="status", status=status, reason=reason)
            )

    def publish_end(self, mission_id: str) -> None:
        """Tell websocket clients a mission ended (as the store now says)."""
        row = self.store.get_mission(mission_id)
        if row is not None:
            end = EndFrame(type="end", status=MissionStatus(row.status), reason=row.reason)
            self.publish(mission_id, end)

    def prune(self) -> int:
        """Delete finished missions older than the retention setting (0 keeps them all)."""
        self.pruned_at = time.monotonic()
        days = self.settings.retention_days
        if days <= 0:
            return 0
        gone = self.store.prune(datetime.now(UTC) - timedelta(days=days))
        if gone:
            log.info("retention: deleted %d missions that ended over %g days ago", gone, days)
        return gone

    def handle(
        self,
        mission_id: str,
        message: WorkerMessage,
        goals: list[dict[str, Any]] | None = None,
    ) -> bool:
        """Store, then broadcast, one worker message; True at the end (``goals``: the
        mission's goals as the server accepted them, stored with its end)."""
        if isinstance(message, Publish | Events):
            frames = []
            for raw in frames_of(message):
                try:
                    frame = parse_frame(raw)
                except ValidationError:  # a bug in the worker: say so, never send it to clients
                    log.exception("mission %s: a frame breaks the protocol", mission_id)
                    continue
                if isinstance(frame, StateFrame):
                    self.trees[mission_id] = frame.tree
                frames.append(frame)
            if len(frames) == 1:
                self.publish(mission_id, frames[0])
            elif frames:
                self.publish_all(mission_id, frames)
        elif isinstance(message, SaveState):
            self.store.save_state(mission_id, message.state)
        elif isinstance(message, Transition):
            self.transition(mission_id, message.status, message.reason, message.state)
        elif isinstance(message, Replanned):
            # replanning (status), the replan (event), then its plan, then executing again
            record = message.record
            self.store.add_replan(mission_id, record)
            self.metrics.replan_latency.observe(record["latency_ms"] / 1000)
            self.transition(mission_id, MissionStatus.REPLANNING, record["trigger"])
            self.publish(
                mission_id,
                ReplanEvent(
                    type="event",
                    kind="replan",
                    t=message.t,
                    trigger=record["trigger"],
                    detail=record["detail"],
                    latency_ms=record["latency_ms"],
                    old=record["old"],
                    new=record["new"],
                    status=record["status"],
                    version=message.version,
                ),
            )
        elif isinstance(message, PlanMade):
            self.store.add_plan(
                mission_id,
                message.version,
                message.domain,
                message.domain_pddl,
                "",
                message.plan,
                message.actions,
                source=message.problem_source,
            )
            self.publish(
                mission_id,
                PlanFrame(
                    type="plan",
                    version=message.version,
                    plan=message.plan,
                    actions=message.actions,
                ),
            )
            if message.version > 1:
                self.transition(mission_id, MissionStatus.EXECUTING)
        elif isinstance(message, Learned):
            if self.library is not None:
                entries = [Primitive.model_validate(e) for e in json.loads(message.entries)]
                self.library.add(message.shape, entries, {"mission_id": mission_id})
                self.library.record(message.shapes)  # the version the mission's event names
        elif isinstance(message, TrajectoryDone):
            self.store.save_trajectory(mission_id, message.points, message.world)
        elif isinstance(message, Ended):
            status, reason = message.status, message.reason
            if status == MissionStatus.CANCELLED and self.shutting_down.is_set():
                status, reason = MissionStatus.FAILED, "interrupted (server shut down)"
            self.end(mission_id, status, reason, message.state, goals)
            return True
        return False

    def end(
        self,
        mission_id: str,
        status: MissionStatus,
        reason: str,
        state: dict[str, Any] | None,
        goals: list[dict[str, Any]] | None = None,
    ) -> None:
        """Store the terminal status (with the last tree and, given, the mission's goals as the
        server accepted them: one added just before the end is in the record, not reached),
        then send the ``end`` frame."""
        tree = self.trees.pop(mission_id, None)
        if (tree is not None or goals is not None) and state is None:
            row = self.store.get_mission(mission_id)
            state = dict(row.state or {}) if row is not None else {}
        if tree is not None:  # kept in the store, no longer in memory (GET /missions/{id}/tree)
            state = {"tree": tree, **(state or {})}  # the worker's final tree, if sent, wins
        if goals is not None:
            state = {**(state or {}), "goals": goals}
        if self.store.transition(mission_id, status, reason, state):
            self.metrics.finished.labels(status).inc()
        if time.monotonic() - self.pruned_at > PRUNE_SECONDS:
            self.prune()
        row = self.store.get_mission(mission_id)
        final = MissionStatus(row.status) if row else status
        end = EndFrame(type="end", status=final, reason=row.reason if row else reason)
        self.publish(mission_id, end)

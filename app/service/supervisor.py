"""The supervisor: runs queued missions concurrently (bounded), off the event loop.

Each running mission is a worker process (``app.service.worker``) that steps its
``MissionRunner`` and paces it (real time × speed, or as fast as possible). A thread here turns
the worker's messages into store writes and then websocket frames, in that order: every
transition, plan and replan is written before it is broadcast. A mission always ends in a
terminal state, also when its worker process dies, outlives the wall-clock limit or ignores
a cancel (it is then stopped). Waiting missions are bounded (``max_queued``) and cost no OS
resources: a mission's cancel event is made when it starts.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import multiprocessing
import os
import queue as queue_module
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from datetime import UTC, datetime, timedelta
from multiprocessing.synchronize import Event as ProcessEvent
from typing import Any

from pydantic import ValidationError
from sqlalchemy.exc import SQLAlchemyError

from app.missions.status import TERMINAL, MissionStatus
from app.service.frames import (
    EndFrame,
    PlanFrame,
    ReplanEvent,
    StateFrame,
    StatusEvent,
    parse_frame,
)
from app.service.hub import Frame, Hub
from app.service.messages import (
    Ended,
    PlanMade,
    Publish,
    Replanned,
    SaveState,
    TrajectoryDone,
    Transition,
    Update,
    WorkerMessage,
)
from app.service.metrics import Metrics
from app.service.reconcile import reconcile
from app.service.worker import run_mission_process
from app.settings import Settings
from app.store.repo import Store
from primitives.library import Library

log = logging.getLogger("screwsnake.supervisor")
CONTEXT = multiprocessing.get_context("forkserver")  # safe beside threads; preloads the code
CONTEXT.set_forkserver_preload(["app.service.worker"])
POLL_SECONDS = 0.5
DRAIN_SECONDS = 0.5  # how long a dead worker's last messages may take to arrive
CANCEL_GRACE = 0.6  # seconds a worker has to honour a cancel before it is stopped
WALL_GRACE = 5.0  # seconds past the wall-clock limit before a worker is stopped
CANCELLED = "cancelled by request"


class QueueFull(Exception):
    """More missions wait than ``max_queued`` allows."""


PRUNE_SECONDS = 3600.0  # wall seconds between retention sweeps


class Supervisor:
    def __init__(
        self, store: Store, library: Library, hub: Hub, settings: Settings, metrics: Metrics
    ) -> None:
        self.store, self.library, self.hub, self.settings, self.metrics = (
            store,
            library,
            hub,
            settings,
            metrics,
        )
        self.pool = ThreadPoolExecutor(settings.max_running, thread_name_prefix="mission")
        self.cancels: dict[str, ProcessEvent] = {}
        self.updates: dict[str, multiprocessing.Queue[Update]] = {}  # running missions' inboxes
        self.running: set[str] = set()
        self.cancel_asked: dict[str, float] = {}  # mission -> monotonic time of its cancel
        self.known: set[str] = set()  # submitted, not started yet (bounded by max_queued)
        self.trees: dict[str, dict[str, Any]] = {}  # running mission -> latest tree snapshot
        self.lock = threading.RLock()
        self.shutting_down = threading.Event()
        self.loop: asyncio.AbstractEventLoop | None = None
        self.queue: asyncio.Queue[str] | None = None
        self.slots: asyncio.Semaphore | None = None
        self.tasks: set[asyncio.Task[Any]] = set()
        self.pruned_at = 0.0  # monotonic time of the last retention sweep

    # -- lifecycle (event loop side) ----------------------------------------------------------
    async def start(self) -> None:
        self.loop = asyncio.get_running_loop()
        self.queue = asyncio.Queue()
        self.slots = asyncio.Semaphore(self.settings.max_running)
        for mission_id in self.store.interrupt_unfinished():
            log.warning(
                "mission %s was running when the server stopped: failed/interrupted", mission_id
            )
        self.store.interrupt_jobs()
        self.prune()
        for mission_id in self.store.queued():
            self.submit(mission_id, force=True)
        self._keep(asyncio.create_task(self._dispatch()))
        self._keep(asyncio.create_task(self._reconcile_periodically()))

    async def stop(self) -> None:
        self.shutting_down.set()
        for event in self.cancels.values():
            event.set()
        for task in list(self.tasks):
            task.cancel()
        await asyncio.get_running_loop().run_in_executor(None, self.pool.shutdown, True)

    def _keep(self, task: asyncio.Task[Any]) -> None:
        self.tasks.add(task)  # a held reference: an unreferenced task can vanish
        task.add_done_callback(self.tasks.discard)

    def full(self) -> bool:
        """Whether a new mission would exceed ``max_queued`` waiting missions."""
        return len(self.known) >= self.settings.max_queued

    def submit(self, mission_id: str, force: bool = False) -> None:
        """Queue a stored mission (from any thread); ``QueueFull`` unless ``force``."""
        assert self.queue is not None and self.loop is not None
        with self.lock:
            if not force and self.full():
                raise QueueFull(mission_id)
            self.known.add(mission_id)
            self.metrics.queued.set(len(self.known))
        try:
            running = asyncio.get_running_loop()
        except RuntimeError:
            running = None
        if running is self.loop:
            self.queue.put_nowait(mission_id)
        else:  # asyncio.Queue is not thread-safe: hand it to the loop
            self.loop.call_soon_threadsafe(self.queue.put_nowait, mission_id)

    async def _reconcile_periodically(self) -> None:
        assert self.loop is not None
        while True:
            await asyncio.sleep(self.settings.reconcile_seconds)
            try:
                await self.loop.run_in_executor(None, reconcile, self.store, self)
            except Exception:  # a database outage: try again next period
                log.exception("reconciliation failed")

    async def _dispatch(self) -> None:
        assert self.queue is not None and self.slots is not None and self.loop is not None
        while True:
            mission_id = await self.queue.get()
            await self.slots.acquire()
            self._keep(asyncio.create_task(self._run(mission_id)))

    async def _run(self, mission_id: str) -> None:
        assert self.slots is not None and self.loop is not None
        try:
            await self.loop.run_in_executor(self.pool, self._work, mission_id)
        except Exception:  # the worker itself already recorded the failure
            log.exception("mission %s worker crashed", mission_id)
        finally:
            self.slots.release()

    def cancel(self, mission_id: str) -> bool:
        """Ask a mission to stop: queued ones end now, running ones within a second (a worker
        that does not stop in ``CANCEL_GRACE`` is stopped)."""
        with self.lock:  # against _work starting it meanwhile
            row = self.store.get_mission(mission_id)
            if row is None or row.status in TERMINAL:
                return False
            if mission_id in self.running:
                self.cancel_asked.setdefault(mission_id, time.monotonic())
                self.cancels[mission_id].set()
                running = True
            else:
                running = False
                ended = self.store.transition(
                    mission_id, MissionStatus.CANCELLED, "cancelled before it started"
                )
                self.known.discard(mission_id)  # its queue entry is skipped when it comes up
                self.metrics.queued.set(len(self.known))
        if running:
            reason = "cancel requested"
            if self.store.transition(mission_id, MissionStatus.CANCELLING, reason):
                self._publish(
                    mission_id,
                    StatusEvent(
                        type="event", kind="status", status=MissionStatus.CANCELLING, reason=reason
                    ),
                )
            return True
        if ended:
            reason = "cancelled before it started"
            self.metrics.finished.labels("cancelled").inc()
            self._publish(
                mission_id, EndFrame(type="end", status=MissionStatus.CANCELLED, reason=reason)
            )
        return True

    def publish_end(self, mission_id: str) -> None:
        """Tell websocket clients a mission ended (as the store now says)."""
        row = self.store.get_mission(mission_id)
        if row is not None:
            end = EndFrame(type="end", status=MissionStatus(row.status), reason=row.reason)
            self._publish(mission_id, end)

    def update(self, mission_id: str, update: Update) -> bool:
        """Send a live update to a running mission's worker; False if it is not running."""
        inbox = self.updates.get(mission_id)
        if inbox is None:
            return False
        inbox.put(update)
        return True

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

    # -- worker thread side --------------------------------------------------------------------
    def _publish(self, mission_id: str, frame: Frame) -> None:
        if self.loop is not None and not self.loop.is_closed():
            self.loop.call_soon_threadsafe(self.hub.publish, mission_id, frame)

    def _transition(
        self,
        mission_id: str,
        status: MissionStatus,
        reason: str = "",
        state: dict[str, Any] | None = None,
    ) -> None:
        if self.store.transition(mission_id, status, reason, state):  # written before broadcast
            self._publish(
                mission_id, StatusEvent(type="event", kind="status", status=status, reason=reason)
            )

    def _work(self, mission_id: str) -> None:
        with self.lock:
            self.known.discard(mission_id)
            self.metrics.queued.set(len(self.known))
            row = self.store.get_mission(mission_id)
            if row is None or row.status != "queued" or mission_id in self.running:
                return  # cancelled while it waited (or queued twice)
            cancel = self.cancels[mission_id] = CONTEXT.Event()
            self.running.add(mission_id)
        self.metrics.running.inc()
        try:
            self._execute(mission_id, row.request, cancel)
        except Exception as exc:  # never leave a mission active: fail it with the reason
            log.exception("mission %s failed unexpectedly", mission_id)
            reason = (
                "database error: the mission's progress could not be saved"
                if isinstance(exc, SQLAlchemyError)
                else f"server error ({type(exc).__name__})"
            )
            with contextlib.suppress(Exception):  # the database may still be down: reconciled
                self._end(mission_id, MissionStatus.FAILED, reason, None)
        finally:
            with self.lock:
                self.running.discard(mission_id)
                self.cancels.pop(mission_id, None)  # its semaphore goes with it
                self.cancel_asked.pop(mission_id, None)
                self.trees.pop(mission_id, None)
            self.metrics.running.dec()

    def _execute(self, mission_id: str, request: dict[str, Any], cancel: ProcessEvent) -> None:
        messages: multiprocessing.Queue[WorkerMessage] = CONTEXT.Queue()
        inbox: multiprocessing.Queue[Update] = CONTEXT.Queue()
        wall_limit = self.settings.wall_limit
        args = (
            mission_id,
            request,
            self.library,  # the copy loaded at start-up, pickled: the file may be gone
            self.settings.ws_rate,
            messages,
            cancel,
            os.getpid(),
            wall_limit,
            inbox,
        )
        process = CONTEXT.Process(
            target=run_mission_process, args=args, name=f"mission-{mission_id[:8]}", daemon=True
        )
        started = time.monotonic()
        process.start()
        self.updates[mission_id] = inbox
        try:
            while True:
                stop = self._overdue(mission_id, started, wall_limit)
                if stop is not None:  # it ignored a cancel or the wall clock: stop it
                    process.kill()
                    self._end(mission_id, *stop, None)
                    return
                try:
                    poll = 0.1 if cancel.is_set() else POLL_SECONDS
                    message = messages.get(timeout=poll)
                except queue_module.Empty:
                    if not process.is_alive():
                        # A worker that exited normally may have its last messages still in
                        # the pipe: drain them before calling it dead.
                        if self._drain(mission_id, messages):
                            return
                        self._end(
                            mission_id,
                            MissionStatus.FAILED,
                            f"worker process died (exit code {process.exitcode})",
                            None,
                        )
                        return
                    continue
                if self._handle(mission_id, message):
                    return
        except BaseException:  # e.g. the store failed: nobody would read the worker any more
            process.kill()
            raise
        finally:
            self.updates.pop(mission_id, None)
            inbox.close()
            inbox.cancel_join_thread()  # updates nobody will read any more
            process.join(timeout=10)
            if process.is_alive():
                process.kill()
            messages.close()
            messages.join_thread()

    def _overdue(
        self, mission_id: str, started: float, wall_limit: float
    ) -> tuple[MissionStatus, str] | None:
        """(status, reason) when a worker must be stopped: a cancel it did not honour within
        ``CANCEL_GRACE``, or a wall-clock limit it overran by ``WALL_GRACE``."""
        now = time.monotonic()
        asked = self.cancel_asked.get(mission_id)
        if asked is not None and now - asked > CANCEL_GRACE:
            return MissionStatus.CANCELLED, CANCELLED
        if now - started > wall_limit + WALL_GRACE:
            return MissionStatus.FAILED, f"wall-clock limit: {wall_limit:g} s reached"
        return None

    def _drain(self, mission_id: str, messages: multiprocessing.Queue[WorkerMessage]) -> bool:
        """Handle what a finished worker left in the queue; True if that ended the mission."""
        while True:
            try:
                message = messages.get(timeout=DRAIN_SECONDS)
            except queue_module.Empty:
                return False
            if self._handle(mission_id, message):
                return True

    def _handle(self, mission_id: str, message: WorkerMessage) -> bool:
        """Store, then broadcast, one worker message; True at the end."""
        if isinstance(message, Publish):
            try:
                frame = parse_frame(message.frame)
            except ValidationError:  # a bug in the worker: say so, never send it to clients
                log.exception("mission %s: a frame breaks the protocol", mission_id)
            else:
                if isinstance(frame, StateFrame):
                    self.trees[mission_id] = frame.tree
                self._publish(mission_id, frame)
        elif isinstance(message, SaveState):
            self.store.save_state(mission_id, message.state)
        elif isinstance(message, Transition):
            self._transition(mission_id, message.status, message.reason, message.state)
        elif isinstance(message, Replanned):
            # replanning (status), the replan (event), then its plan, then executing again
            record = message.record
            self.store.add_replan(mission_id, record)
            self.metrics.replan_latency.observe(record["latency_ms"] / 1000)
            self._transition(mission_id, MissionStatus.REPLANNING, record["trigger"])
            self._publish(
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
                message.problem_pddl,
                message.plan,
                message.actions,
            )
            self._publish(
                mission_id,
                PlanFrame(
                    type="plan",
                    version=message.version,
                    plan=message.plan,
                    actions=message.actions,
                ),
            )
            if message.version > 1:
                self._transition(mission_id, MissionStatus.EXECUTING)
        elif isinstance(message, TrajectoryDone):
            self.store.save_trajectory(mission_id, message.points)
        elif isinstance(message, Ended):
            status, reason = message.status, message.reason
            if status == MissionStatus.CANCELLED and self.shutting_down.is_set():
                status, reason = MissionStatus.FAILED, "interrupted (server shut down)"
            self._end(mission_id, status, reason, message.state)
            return True
        return False

    def _end(
        self,
        mission_id: str,
        status: MissionStatus,
        reason: str,
        state: dict[str, Any] | None,
    ) -> None:
        tree = self.trees.pop(mission_id, None)
        if tree is not None:  # kept in the store, no longer in memory (GET /missions/{id}/tree)
            if state is None:
                row = self.store.get_mission(mission_id)
                state = dict(row.state or {}) if row is not None else {}
            state = {"tree": tree, **state}  # the worker's final tree, when it sent one, wins
        if self.store.transition(mission_id, status, reason, state):
            self.metrics.finished.labels(status).inc()
        if time.monotonic() - self.pruned_at > PRUNE_SECONDS:
            self.prune()
        row = self.store.get_mission(mission_id)
        final = MissionStatus(row.status) if row else status
        end = EndFrame(type="end", status=final, reason=row.reason if row else reason)
        self._publish(mission_id, end)

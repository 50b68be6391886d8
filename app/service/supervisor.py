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
from multiprocessing.synchronize import Event as ProcessEvent
from typing import Any

from sqlalchemy.exc import SQLAlchemyError

from app.service.hub import Frame, Hub
from app.service.metrics import Metrics
from app.service.reconcile import reconcile
from app.service.worker import Message, run_mission_process
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
            if row is None or row.status in ("succeeded", "failed", "cancelled"):
                return False
            if mission_id in self.running:
                self.cancel_asked.setdefault(mission_id, time.monotonic())
                self.cancels[mission_id].set()
                running = True
            else:
                running = False
                ended = self.store.transition(
                    mission_id, "cancelled", "cancelled before it started"
                )
                self.known.discard(mission_id)  # its queue entry is skipped when it comes up
                self.metrics.queued.set(len(self.known))
        if running:
            if self.store.transition(mission_id, "cancelling", "cancel requested"):
                self._publish(
                    mission_id, {"type": "event", "kind": "status", "status": "cancelling"}
                )
            return True
        if ended:
            self.metrics.finished.labels("cancelled").inc()
            self._publish(
                mission_id,
                {"type": "end", "status": "cancelled", "reason": "cancelled before it started"},
            )
        return True

    def publish_end(self, mission_id: str) -> None:
        """Tell websocket clients a mission ended (as the store now says)."""
        row = self.store.get_mission(mission_id)
        if row is not None:
            self._publish(mission_id, {"type": "end", "status": row.status, "reason": row.reason})

    # -- worker thread side --------------------------------------------------------------------
    def _publish(self, mission_id: str, frame: Frame) -> None:
        if self.loop is not None and not self.loop.is_closed():
            self.loop.call_soon_threadsafe(self.hub.publish, mission_id, frame)

    def _transition(
        self, mission_id: str, status: str, reason: str = "", state: dict[str, Any] | None = None
    ) -> None:
        if self.store.transition(mission_id, status, reason, state):  # written before broadcast
            self._publish(
                mission_id, {"type": "event", "kind": "status", "status": status, "reason": reason}
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
                self._end(mission_id, "failed", reason, None)
        finally:
            with self.lock:
                self.running.discard(mission_id)
                self.cancels.pop(mission_id, None)  # its semaphore goes with it
                self.cancel_asked.pop(mission_id, None)
                self.trees.pop(mission_id, None)
            self.metrics.running.dec()

    def _execute(self, mission_id: str, request: dict[str, Any], cancel: ProcessEvent) -> None:
        messages: multiprocessing.Queue[Message] = CONTEXT.Queue()
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
        )
        process = CONTEXT.Process(
            target=run_mission_process, args=args, name=f"mission-{mission_id[:8]}", daemon=True
        )
        started = time.monotonic()
        process.start()
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
                            "failed",
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
            process.join(timeout=10)
            if process.is_alive():
                process.kill()
            messages.close()
            messages.join_thread()

    def _overdue(
        self, mission_id: str, started: float, wall_limit: float
    ) -> tuple[str, str] | None:
        """(status, reason) when a worker must be stopped: a cancel it did not honour within
        ``CANCEL_GRACE``, or a wall-clock limit it overran by ``WALL_GRACE``."""
        now = time.monotonic()
        asked = self.cancel_asked.get(mission_id)
        if asked is not None and now - asked > CANCEL_GRACE:
            return "cancelled", CANCELLED
        if now - started > wall_limit + WALL_GRACE:
            return "failed", f"wall-clock limit: {wall_limit:g} s reached"
        return None

    def _drain(self, mission_id: str, messages: multiprocessing.Queue[Message]) -> bool:
        """Handle what a finished worker left in the queue; True if that ended the mission."""
        while True:
            try:
                message = messages.get(timeout=DRAIN_SECONDS)
            except queue_module.Empty:
                return False
            if self._handle(mission_id, message):
                return True

    def _handle(self, mission_id: str, message: Message) -> bool:
        """Store, then broadcast, one worker message; True at the end."""
        kind = message[0]
        if kind == "frame":
            frame = message[1]
            if frame.get("type") == "state" and "tree" in frame:
                self.trees[mission_id] = frame["tree"]
            self._publish(mission_id, frame)
        elif kind == "state":
            self.store.save_state(mission_id, message[1])
        elif kind == "transition":
            self._transition(mission_id, message[1], message[2], message[3])
        elif kind == "plan":
            _, version, domain, domain_pddl, problem_pddl, plan, actions = message
            self.store.add_plan(
                mission_id, version, domain, domain_pddl, problem_pddl, plan, actions
            )
            self._publish(
                mission_id, {"type": "plan", "version": version, "plan": plan, "actions": actions}
            )
        elif kind == "replan":
            record = message[1]
            self.store.add_replan(mission_id, record)
            self.metrics.replan_latency.observe(record["latency_ms"] / 1000)
            self._transition(mission_id, "replanning", record["trigger"])
            self._transition(mission_id, "executing")
            self._publish(mission_id, {"type": "event", "kind": "replan", **record})
        elif kind == "trajectory":
            self.store.save_trajectory(mission_id, message[1])
        elif kind == "end":
            _, status, reason, state = message
            if status == "cancelled" and self.shutting_down.is_set():
                status, reason = "failed", "interrupted (server shut down)"
            self._end(mission_id, status, reason, state)
            return True
        return False

    def _end(self, mission_id: str, status: str, reason: str, state: dict[str, Any] | None) -> None:
        tree = self.trees.pop(mission_id, None)
        if tree is not None:  # kept in the store, no longer in memory (GET /missions/{id}/tree)
            if state is None:
                row = self.store.get_mission(mission_id)
                state = dict(row.state or {}) if row is not None else {}
            state = {**state, "tree": tree}
        if self.store.transition(mission_id, status, reason, state):
            self.metrics.finished.labels(status).inc()
        row = self.store.get_mission(mission_id)
        final = row.status if row else status
        self._publish(
            mission_id, {"type": "end", "status": final, "reason": row.reason if row else reason}
        )

"""The supervisor: runs queued missions on a warm pool of workers, off the event loop.

The pool (``app.service.pool``: local processes, or Ray actors) starts with the service; each
worker runs one mission after another, so a mission starts without waiting for a process. A
thread here per running mission reads its worker's messages and hands them to the relay
(``app.service.relay``: stored, then broadcast). A mission always ends in a terminal state, also
when its worker dies, outlives the wall-clock limit or ignores a cancel: the worker is then
killed and replaced, and the mission ends with the reason. A worker that dies while idle is
replaced too (within ``IDLE_CHECK_SECONDS``), and ``warmth`` says how many workers have finished
their warm-up (``/readyz``). Waiting missions are bounded (``max_queued``) and cost no OS
resources.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import threading
import time
from typing import Any

from sqlalchemy.exc import SQLAlchemyError

from app.missions.maps import referenced
from app.missions.status import TERMINAL, MissionStatus
from app.service.frames import EndFrame, StatusEvent
from app.service.hub import Hub
from app.service.library import SharedLibrary
from app.service.live import LiveMission
from app.service.maps import stored_maps
from app.service.messages import Ended, Job, Update
from app.service.metrics import Metrics
from app.service.pool import Worker, WorkerLost, make_workers
from app.service.reconcile import reconcile
from app.service.relay import Relay
from app.settings import Settings
from app.store.repo import Store

log = logging.getLogger("screwsnake.supervisor")
POLL_SECONDS = 0.5
CANCEL_POLL_SECONDS = 0.1  # how often a cancelled mission's worker is looked at
CANCEL_GRACE = 0.6  # seconds a worker has to honour a cancel before it is stopped
WALL_GRACE = 5.0  # seconds past the wall-clock limit before a worker is stopped
MEMORY_POLL_SECONDS = 0.2  # how often a running mission's worker's memory is looked at
CANCELLED = "cancelled by request"
# How often idle workers are looked at: one that died idle is replaced then, not only when a
# mission comes for it (a dead worker is never warm: a pool of them would keep /readyz at 503,
# and a service that is not ready may get no mission to replace them).
IDLE_CHECK_SECONDS = 2.0


class QueueFull(Exception):
    """More missions wait than ``max_queued`` allows."""


class Supervisor:
    def __init__(
        self, store: Store, library: SharedLibrary, hub: Hub, settings: Settings, metrics: Metrics
    ) -> None:
        self.store, self.hub = store, hub
        self.shared = library  # jobs carry the shapes learned since the workers started
        self.library = library.library  # what the workers start with
        self.settings, self.metrics = settings, metrics
        self.relay = Relay(store, hub, settings, metrics, library)
        self.relay.on_status = self._status_stored
        self.workers: list[Worker] = []  # the pool, started with the service
        # A thread per running mission (at most max_running), a daemon: one stuck in a call
        # that never returns (a worker hung in native code, a call to a lost Ray node) cannot
        # hold the server's exit once the bounded shutdown gave up on it.
        self.threads: set[threading.Thread] = set()
        self.assigned: dict[str, Worker] = {}  # running mission -> its worker
        # Running mission -> the server's account of its goals, live obstacles and pause
        # (``app.service.live``): the one owner the live-update routes read and change.
        self.live: dict[str, LiveMission] = {}
        self.running: set[str] = set()
        self.cancel_asked: dict[str, float] = {}  # mission -> monotonic time of its cancel
        self.known: set[str] = set()  # submitted, not started yet (bounded by max_queued)
        # Missions whose end could not be written (the database failed): the reconciliation
        # ends them with this status and reason once it can, not as "worker lost".
        self.unended: dict[str, tuple[MissionStatus, str]] = {}
        self.lock = threading.RLock()
        self.loop: asyncio.AbstractEventLoop | None = None
        self.queue: asyncio.Queue[str] | None = None
        self.idle: asyncio.Queue[Worker] | None = None
        self.tasks: set[asyncio.Task[Any]] = set()

    @property
    def shutting_down(self) -> threading.Event:
        return self.relay.shutting_down

    # -- lifecycle (event loop side) ----------------------------------------------------------
    async def start(self) -> None:
        self.loop = self.relay.loop = asyncio.get_running_loop()
        self.queue = asyncio.Queue()
        self.idle = asyncio.Queue()
        if self.settings.executor == "ray":
            # On this thread, not a passing executor thread: a local Ray instance's processes
            # die with the thread that started them. (Once, before the service answers.)
            from app.service.ray_pool import connect

            connect(self.settings)
        # Starting processes (or actors) blocks: not on the event loop.
        self.workers = await self.loop.run_in_executor(
            None, make_workers, self.settings, self.library
        )
        for worker in self.workers:
            self.idle.put_nowait(worker)
        for mission_id in self.store.interrupt_unfinished():
            log.warning(
                "mission %s was running when the server stopped: failed/interrupted", mission_id
            )
        self.store.interrupt_jobs()
        self.relay.prune()
        for mission_id in self.store.queued():
            self.submit(mission_id, force=True)
        self._keep(asyncio.create_task(self._dispatch()))
        self._keep(asyncio.create_task(self._reconcile_periodically()))
        self._keep(asyncio.create_task(self._replace_dead_idle()))

    async def stop(self) -> None:
        """Stop within ``shutdown_seconds``: running missions are asked to stop (each ends
        ``failed: interrupted (server shut down)``, its worker stopped), then every worker is
        stopped, killed if it does not go; whatever is still stuck then is left behind (daemon
        threads), and a mission still active is failed ``interrupted`` at the next start."""
        deadline = time.monotonic() + self.settings.shutdown_seconds
        self.shutting_down.set()
        with self.lock:
            for mission_id, worker in self.assigned.items():
                self.cancel_asked.setdefault(mission_id, time.monotonic())  # stopped if stuck
                worker.cancel()
        for task in list(self.tasks):
            task.cancel()
        loop = asyncio.get_running_loop()
        await loop.run_in_executor(None, self._join_missions, deadline)
        left = await loop.run_in_executor(None, self._stop_workers, deadline)
        if left:
            log.error("shutdown: %d mission workers did not stop in time: left behind", left)
        self.workers = []  # their channels are freed now, not reported leaked at exit
        self.idle = None

    def _join_missions(self, deadline: float) -> None:
        """Wait for the mission threads until ``deadline`` (each ends its mission)."""
        for thread in list(self.threads):
            thread.join(max(0.0, deadline - time.monotonic()))
        stuck = [t.name for t in self.threads if t.is_alive()]
        if stuck:
            log.error("shutdown: mission threads still running at the deadline: %s", stuck)

    def _stop_workers(self, deadline: float) -> int:
        """Stop every worker at once, each in a daemon thread, until ``deadline``; how many
        had not stopped by then."""
        grace = max(0.1, deadline - time.monotonic())
        stoppers = [
            threading.Thread(target=w.stop, args=(grace,), daemon=True, name="stop-worker")
            for w in self.workers
        ]
        for thread in stoppers:
            thread.start()
        for thread in stoppers:
            thread.join(max(0.0, deadline - time.monotonic()) + 1.0)  # (a kill takes a moment)
        return sum(thread.is_alive() for thread in stoppers)

    def _keep(self, task: asyncio.Task[Any]) -> None:
        self.tasks.add(task)  # a held reference: an unreferenced task can vanish
        task.add_done_callback(self.tasks.discard)

    def full(self) -> bool:
        """Whether a new mission would exceed ``max_queued`` waiting missions."""
        return len(self.known) >= self.settings.max_queued

    def room(self) -> int:
        """How many more missions may wait now (``max_queued`` less those waiting)."""
        return max(0, self.settings.max_queued - len(self.known))

    def warmth(self) -> tuple[int, int]:
        """(workers warm now, workers in the pool): a worker is warm once its warm-up ended
        and for as long as it lives; its replacement starts cold. Never blocks."""
        warm = sum(1 for worker in list(self.workers) if worker.warm())
        return warm, self.settings.max_running

    def submit(self, mission_id: str, force: bool = False) -> None:
        """Queue a stored mission (from any thread); ``QueueFull`` unless ``force``."""
        assert self.queue is not None and self.loop is not None
        if force:
            # Without the lock: a set's add is atomic, and a mission thread may hold the lock
            # through a store read (a burst's batch waited milliseconds per mission for it).
            self.known.add(mission_id)
        else:
            with self.lock:  # the check and the add at once
                if self.full():
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

    async def _replace_dead_idle(self) -> None:
        """Every ``IDLE_CHECK_SECONDS``, replace the idle workers that died (killed, out of
        memory). Each is out of the idle queue while it is looked at and replaced, so no
        mission takes it meanwhile."""
        assert self.loop is not None
        while True:
            await asyncio.sleep(IDLE_CHECK_SECONDS)
            idle = self.idle
            if idle is None or self.shutting_down.is_set():
                return
            held = [idle.get_nowait() for _ in range(idle.qsize())]
            dead = [worker for worker in held if not worker.alive()]
            for worker in held:
                if worker not in dead:
                    idle.put_nowait(worker)
            for worker in dead:
                log.warning("an idle mission worker died: replaced")
                try:
                    await self.loop.run_in_executor(None, self._replace, worker)
                finally:
                    idle.put_nowait(worker)  # (a failed restart: _work tries again)

    async def _dispatch(self) -> None:
        assert self.queue is not None and self.idle is not None
        while True:
            mission_id = await self.queue.get()
            worker = await self.idle.get()  # the next mission waits for a free worker
            self._keep(asyncio.create_task(self._run(mission_id, worker)))

    async def _run(self, mission_id: str, worker: Worker) -> None:
        loop = asyncio.get_running_loop()
        finished: asyncio.Future[None] = loop.create_future()

        def done() -> None:
            if not finished.done():
                finished.set_result(None)

        def work() -> None:
            try:
                self._work(mission_id, worker)
            except Exception:  # the mission itself already recorded the failure
                log.exception("mission %s: its thread crashed", mission_id)
            finally:
                self.threads.discard(thread)
                with contextlib.suppress(RuntimeError):  # the loop is gone: nobody waits
                    loop.call_soon_threadsafe(done)

        thread = threading.Thread(target=work, daemon=True, name=f"mission-{mission_id[:8]}")
        self.threads.add(thread)
        thread.start()
        try:
            await finished
        finally:
            if self.idle is not None and not self.shutting_down.is_set():
                self.idle.put_nowait(worker)

    def cancel(self, mission_id: str) -> bool:
        """Ask a mission to stop: queued ones end now, running ones within a second (a worker
        that does not stop in ``CANCEL_GRACE`` is killed and replaced)."""
        with self.lock:  # against _work starting it meanwhile
            row = self.store.get_mission(mission_id)
            if row is None or row.status in TERMINAL:
                return False
            started = mission_id in self.running
            if started:
                live = self.live.get(mission_id)
                if live is not None:  # no live update applies from now on
                    live.stopping = "cancelling"
                self.cancel_asked.setdefault(mission_id, time.monotonic())
                worker = self.assigned.get(mission_id)
                if worker is not None:  # else _work passes it on when the worker has begun
                    worker.cancel()
                ended = False
            else:
                ended = self.store.transition(
                    mission_id, MissionStatus.CANCELLED, "cancelled before it started"
                )
                self.known.discard(mission_id)  # its queue entry is skipped when it comes up
                self.metrics.queued.set(len(self.known))
        if started:
            reason = "cancel requested"
            if self.store.transition(mission_id, MissionStatus.CANCELLING, reason):
                self.relay.publish(
                    mission_id,
                    StatusEvent(
                        type="event", kind="status", status=MissionStatus.CANCELLING, reason=reason
                    ),
                )
            return True
        if ended:
            reason = "cancelled before it started"
            self.metrics.finished.labels("cancelled").inc()
            self.relay.publish(
                mission_id, EndFrame(type="end", status=MissionStatus.CANCELLED, reason=reason)
            )
        return True

    def _status_stored(self, mission_id: str, status: MissionStatus) -> None:
        """A status change was stored: the live account follows it."""
        live = self.live.get(mission_id)
        if live is not None:
            live.status = status

    def live_goals(self, mission_id: str) -> list[dict[str, Any]] | None:
        """A running mission's goals as its live account has them (None: not running)."""
        live = self.live.get(mission_id)
        return live.goals_now() if live is not None else None

    def publish_end(self, mission_id: str) -> None:
        """Tell websocket clients a mission ended (as the store now says)."""
        self.relay.publish_end(mission_id)

    def update(self, mission_id: str, update: Update) -> bool:
        """Send a live update to a running mission's worker; False if it is not running."""
        with self.lock:
            worker = self.assigned.get(mission_id)
        if worker is None:
            return False
        worker.update(mission_id, update)
        return True

    def prune(self) -> int:
        """Delete finished missions older than the retention setting (0 keeps them all)."""
        return self.relay.prune()

    # -- mission thread side -------------------------------------------------------------------
    def _work(self, mission_id: str, worker: Worker) -> None:
        if not worker.alive():  # it died while idle: a fresh one takes its place
            log.warning("an idle mission worker died: replaced")
            worker.restart()
        with self.lock:
            self.known.discard(mission_id)
            self.metrics.queued.set(len(self.known))
            row = self.store.get_mission(mission_id)
            if row is None or row.status != "queued" or mission_id in self.running:
                return  # cancelled while it waited (or queued twice)
            self.running.add(mission_id)
        self.metrics.running.inc()
        try:
            # Not under the lock (a Ray actor may still be starting): a cancel meanwhile is
            # remembered in cancel_asked and passed on once the worker runs this mission.
            maps = stored_maps(self.store, referenced(row.request))
            job = Job(
                mission_id,
                row.request,
                self.settings.wall_limit,
                maps,
                self.shared.learned(),
                self.settings.learn_budget,
            )
            try:
                worker.begin(job)
            except WorkerLost:  # it died while idle (e.g. a lost Ray node): once more, afresh
                log.warning("mission %s: its worker was gone; replaced", mission_id)
                worker.restart()
                worker.begin(job)
            with self.lock:
                self.assigned[mission_id] = worker
                live = LiveMission.of(mission_id, row.request, maps)
                if mission_id in self.cancel_asked:
                    worker.cancel()
                    live.stopping = "cancelling"
                self.live[mission_id] = live
            self._execute(mission_id, worker)
        except Exception as exc:  # never leave a mission active: fail it with the reason
            log.exception("mission %s failed unexpectedly", mission_id)
            if isinstance(exc, WorkerLost):
                reason = str(exc)
            elif isinstance(exc, SQLAlchemyError):
                reason = "database error: the mission's progress could not be saved"
            else:
                reason = f"server error ({type(exc).__name__})"
            self._replace(worker)  # nobody reads that mission's messages any more: stop it
            try:
                self.relay.end(mission_id, MissionStatus.FAILED, reason, None)
            except Exception:  # the database may still be down: reconciled, with this reason
                log.warning(
                    "mission %s: its end could not be written; reconciled later", mission_id
                )
                with self.lock:
                    self.unended[mission_id] = (MissionStatus.FAILED, reason)
        finally:
            with self.lock:
                self.running.discard(mission_id)
                self.assigned.pop(mission_id, None)
                gone = self.live.pop(mission_id, None)
                if gone is not None:
                    gone.stopping = "ended"
                self.cancel_asked.pop(mission_id, None)
                self.relay.trees.pop(mission_id, None)
            self.metrics.running.dec()

    def _execute(self, mission_id: str, worker: Worker) -> None:
        """Relay the worker's messages until the mission ends; stop a worker that died, hangs
        past the wall clock or ignores a cancel (the mission ends with the reason first)."""
        started = time.monotonic()
        wall_limit = self.settings.wall_limit
        checked = 0.0  # when the worker's memory was last looked at
        while True:
            look = time.monotonic() - checked >= MEMORY_POLL_SECONDS
            checked = time.monotonic() if look else checked
            stop = self._overdue(mission_id, started, wall_limit, worker if look else None)
            if stop is not None:
                self.relay.end(mission_id, *stop, None, self.live_goals(mission_id))
                self._replace(worker)
                return
            poll = CANCEL_POLL_SECONDS if mission_id in self.cancel_asked else POLL_SECONDS
            try:
                batch = worker.messages(poll)
            except WorkerLost as exc:
                goals = self.live_goals(mission_id)
                self.relay.end(mission_id, MissionStatus.FAILED, str(exc), None, goals)
                self._replace(worker)
                return
            live = self.live.get(mission_id)
            for message in batch:
                if live is not None:
                    live.observe(message)  # what the worker says of its goals, before relaying
                goals = self.live_goals(mission_id) if isinstance(message, Ended) else None
                if self.relay.handle(mission_id, message, goals):
                    return

    def _replace(self, worker: Worker) -> None:
        """Kill a worker that must not go on and start a fresh one (none while stopping)."""
        if self.shutting_down.is_set():
            worker.stop()
        else:
            worker.restart()

    def _overdue(
        self, mission_id: str, started: float, wall_limit: float, worker: Worker | None = None
    ) -> tuple[MissionStatus, str] | None:
        """(status, reason) when a worker must be stopped: a cancel it did not honour within
        ``CANCEL_GRACE``, a wall-clock limit it overran by ``WALL_GRACE``, or more resident
        memory than ``SCREWSNAKE_WORKER_MEMORY``."""
        now = time.monotonic()
        rss = worker.memory() if worker is not None else None
        limit = self.settings.worker_memory_bytes
        if rss is not None and rss > limit:
            return MissionStatus.FAILED, (
                f"memory limit: the worker used {rss / 2**20:.0f} MB, over "
                f"SCREWSNAKE_WORKER_MEMORY ({limit / 2**20:.0f} MB)"
            )
        asked = self.cancel_asked.get(mission_id)
        if asked is not None and now - asked > CANCEL_GRACE:
            if self.shutting_down.is_set():
                return MissionStatus.FAILED, "interrupted (server shut down)"
            return MissionStatus.CANCELLED, CANCELLED
        if now - started > wall_limit + WALL_GRACE:
            return MissionStatus.FAILED, f"wall-clock limit: {wall_limit:g} s reached"
        return None

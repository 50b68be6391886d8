"""The warm worker pool: long-lived processes, each running missions one after another.

A mission no longer waits for a process to start (and to import numpy, the planner and the
library): the pool's processes start with the service, get the library once, and take one
``Job`` after another. Each worker has its own channels, so a worker that dies, hangs or ignores
a cancel is killed and replaced without touching the others. ``Worker`` is the interface the
supervisor drives; ``app.service.ray_pool`` implements it with Ray actors. A worker is *warm*
once its warm-up has ended (``Worker.warm``): the service is ready (``/readyz``) only when
enough of them are; a replaced worker is cold again until its own warm-up ends.
"""

from __future__ import annotations

import multiprocessing
import os
import queue as queue_module
from multiprocessing.queues import Queue
from typing import Protocol

from app.executor.warm import warm_up
from app.service.messages import Addressed, Job, Update, WorkerMessage
from app.service.worker import SharedFlag, WarmUp, resident_bytes, serve_missions
from app.settings import Settings
from primitives.library import Library

CONTEXT = multiprocessing.get_context("forkserver")  # safe beside threads; preloads the code
CONTEXT.set_forkserver_preload(["app.service.worker"])
DRAIN_SECONDS = 0.5  # how long a dead worker's last messages may take to arrive
STOP_SECONDS = 5.0  # how long a worker may take to exit when the service stops


class WorkerLost(Exception):
    """The worker is gone (its process died, its actor was lost); the message is the reason."""


class Worker(Protocol):
    """One slot of the pool: runs a mission at a time, reports its messages."""

    def begin(self, job: Job) -> None:
        """Start a mission (the worker is idle); its cancel flag starts clear."""
        ...

    def messages(self, timeout: float) -> list[WorkerMessage]:
        """The next messages of the running mission (empty after ``timeout`` seconds without
        any); ``WorkerLost`` when the worker is gone and nothing is left to read."""
        ...

    def cancel(self) -> None:
        """Ask the running mission to stop (the worker honours it within its next tick)."""
        ...

    def update(self, mission_id: str, update: Update) -> None:
        """Send a live update to the running mission."""
        ...

    def alive(self) -> bool:
        """Whether the worker can take a mission."""
        ...

    def memory(self) -> int | None:
        """The worker's resident memory in bytes, as last known (None: not known). Never
        blocks."""
        ...

    def warm(self) -> bool:
        """Whether the worker has finished its warm-up (and is still there): a mission given
        now starts at once. Never blocks."""
        ...

    def restart(self) -> None:
        """Kill the worker (whatever it is doing) and start a fresh one in its place."""
        ...

    def stop(self, timeout: float = STOP_SECONDS) -> None:
        """Ask the worker to exit, killing it if it has not within ``timeout`` seconds (the
        service's shutdown)."""
        ...


class ProcessWorker:
    """A worker process on this machine (``forkserver``: cheap to start, safe beside threads)."""

    def __init__(
        self, index: int, library: Library, settings: Settings, warm: WarmUp | None = warm_up
    ) -> None:
        self.index, self.library, self.settings = index, library, settings
        self.warm_up = warm if settings.warm_up else None  # None: warm once it has started
        self._spawn()

    def _spawn(self) -> None:
        self.jobs: Queue[Job | None] = CONTEXT.Queue()
        self.outbox: Queue[WorkerMessage] = CONTEXT.Queue()
        self.updates: Queue[Addressed] = CONTEXT.Queue()
        self.cancel_flag = SharedFlag(CONTEXT.RawValue("b", 0))
        # Raised by the process once warm; a fresh one per process, so a replacement starts cold.
        self.warm_flag = SharedFlag(CONTEXT.RawValue("b", 0))
        args = (
            self.jobs,
            self.outbox,
            self.cancel_flag,
            self.updates,
            self.library,  # the copy loaded at start-up, pickled once per process
            self.settings.ws_rate,
            os.getpid(),
            self.settings.worker_nice,
            self.warm_up,
            self.warm_flag,
            self.settings.worker_memory_bytes,  # its caches sized to its limit
        )
        self.process = CONTEXT.Process(
            target=serve_missions, args=args, name=f"mission-worker-{self.index}", daemon=True
        )
        self.process.start()

    @property
    def pid(self) -> int | None:
        return self.process.pid

    def begin(self, job: Job) -> None:
        self.cancel_flag.clear()  # a cancel of the previous mission must not stop this one
        self.jobs.put(job)

    def messages(self, timeout: float) -> list[WorkerMessage]:
        try:
            return [self.outbox.get(timeout=timeout)]
        except queue_module.Empty:
            pass
        if self.process.is_alive():
            return []
        # It died, but its last messages may still be in the pipe: hand them over first.
        try:
            return [self.outbox.get(timeout=DRAIN_SECONDS)]
        except queue_module.Empty:
            raise WorkerLost(f"worker process died (exit code {self.process.exitcode})") from None

    def cancel(self) -> None:
        self.cancel_flag.set()

    def update(self, mission_id: str, update: Update) -> None:
        self.updates.put(Addressed(mission_id, update))

    def alive(self) -> bool:
        return self.process.is_alive()

    def memory(self) -> int | None:
        return resident_bytes(self.process.pid) if self.process.pid else None

    def warm(self) -> bool:
        return self.warm_flag.is_set() and self.process.is_alive()

    def restart(self) -> None:
        self._kill()
        self._spawn()

    def stop(self, timeout: float = STOP_SECONDS) -> None:
        self.cancel_flag.set()
        # Still warming up, it runs no mission and reads no job until the warm-up ends (seconds
        # of CPU that nobody will use): killed at once.
        if self.process.is_alive() and self.warm_flag.is_set():
            self.jobs.put(None)
            self.process.join(timeout=timeout)
        self._kill()

    def _kill(self) -> None:
        if self.process.is_alive():
            self.process.kill()
        self.process.join(timeout=10)
        for channel in (self.jobs, self.outbox, self.updates):
            channel.close()
            channel.cancel_join_thread()  # nobody reads them any more: never block on them


def make_workers(settings: Settings, library: Library, warm: WarmUp = warm_up) -> list[Worker]:
    """The pool the settings ask for: ``max_running`` local processes or Ray actors, each
    running ``warm`` first (when the settings ask for a warm-up)."""
    if settings.executor == "ray":
        from app.service.ray_pool import make_ray_workers  # connected by then (``connect``)

        return list(make_ray_workers(settings, library, warm))
    return [ProcessWorker(i, library, settings, warm) for i in range(settings.max_running)]

"""Missions on Ray (``SCREWSNAKE_EXECUTOR=ray``): each pool slot is a Ray actor.

The actor runs one mission at a time in a thread and buffers its messages; the supervisor polls
them (``poll``, a batch at a time) and relays them to the store and the websocket hub, which stay
in the service process. Cancel and live updates are actor calls. A lost actor (its node died,
it was killed) ends its mission ``failed`` and is replaced. ``SCREWSNAKE_RAY_ADDRESS`` names a
cluster; unset, a local Ray instance is started (or the one this process already runs). An
actor warms up in its constructor, so its first answer (``ready``) says it is warm.
"""

from __future__ import annotations

import contextlib
import logging
import os
import queue as queue_module
import signal
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from app.executor.warm import warm_up
from app.service.messages import Addressed, Job, Update, WorkerMessage
from app.service.pool import WorkerLost
from app.service.worker import WarmUp, budget_caches, resident_bytes, run_mission
from app.settings import Settings, cores, max_obstacles
from primitives.library import Library

log = logging.getLogger("screwsnake.ray")
POLL_BATCH = 256  # most messages one poll returns
CALL_SECONDS = 60.0  # longest wait for an actor to answer a call that must succeed
POLL_SLACK = 5.0  # seconds a poll may take beyond its own timeout before it is waited on again
PACKAGES = ("app", "domain", "primitives", "sim")  # shipped to a cluster with each job


class MissionActor:
    """Runs missions one after another on a Ray worker; polled for their messages."""

    def __init__(
        self,
        library: Library,
        ws_rate: float,
        niceness: int,
        warm: WarmUp | None,
        memory: int | None = None,
    ) -> None:
        if niceness:
            with contextlib.suppress(OSError):
                os.nice(niceness)  # on a shared machine the API keeps priority
        if memory is not None:
            budget_caches(memory)  # the planner's caches sized to the actor's limit
        self.library, self.ws_rate = library, ws_rate
        if warm is not None:  # in the constructor: no call (``ready``, ``begin``) runs before
            warm(library)  # kernels and motion tables loaded before the first mission comes
        self.outbox: queue_module.Queue[WorkerMessage] = queue_module.Queue()
        self.updates: queue_module.Queue[Addressed] = queue_module.Queue()
        self.cancel_flag = threading.Event()
        self.thread: threading.Thread | None = None

    def ready(self) -> int:
        """Answers once the actor has started and warmed up: its pid."""
        return os.getpid()

    def begin(self, job: Job) -> int:
        """Start a mission in a thread; the actor's pid."""
        if self.thread is not None:
            self.thread.join()  # the previous mission sent Ended: its thread is ending
        self.cancel_flag.clear()
        args = (job, self.library, self.ws_rate, self.outbox, self.cancel_flag, self.updates)
        self.thread = threading.Thread(target=run_mission, args=args, daemon=True)
        self.thread.start()
        return os.getpid()

    def poll(self, timeout: float) -> list[WorkerMessage]:
        """The messages sent since the last poll (waits up to ``timeout`` for the first)."""
        try:
            out = [self.outbox.get(timeout=timeout)]
        except queue_module.Empty:
            return []
        while len(out) < POLL_BATCH:
            try:
                out.append(self.outbox.get_nowait())
            except queue_module.Empty:
                break
        return out

    def cancel(self) -> None:
        self.cancel_flag.set()

    def update(self, item: Addressed) -> None:
        self.updates.put(item)

    def rss(self) -> int | None:
        """This actor's resident memory in bytes (the server enforces its limit)."""
        return resident_bytes()


def connect(settings: Settings) -> None:
    """Attach to the cluster at ``ray_address``, or start a local Ray instance (once)."""
    import ray

    if ray.is_initialized():
        return
    # ray.init replaces SIGTERM's handler with one that exits at once: keep the server's
    # (uvicorn's graceful shutdown, which stops the pool and ends running missions).
    with restored(signal.SIGTERM):
        init(settings)
    log.info("missions run on Ray (%s)", settings.ray_address or "a local instance")


@contextlib.contextmanager
def restored(signum: int) -> Iterator[None]:
    """Put a signal's handler back as it was after the block (on the main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.getsignal(signum)
    try:
        yield
    finally:
        if previous is not None:  # None: set outside Python, cannot be put back
            signal.signal(signum, previous)


def init(settings: Settings) -> None:
    """``ray.init`` for the settings: the cluster, with this project's code, or a local one."""
    import ray

    if settings.ray_address:
        # The code goes with the job; third-party packages must be installed on the nodes.
        root = Path(__file__).resolve().parents[2]
        modules = [str(root / name) for name in PACKAGES]
        # A cluster's actors do not inherit this environment; they validate missions again.
        env = {"SCREWSNAKE_MAX_OBSTACLES": str(max_obstacles())}
        ray.init(
            address=settings.ray_address,
            runtime_env={"py_modules": modules, "env_vars": env},
            log_to_driver=False,
        )
    else:
        ray.init(
            num_cpus=max(cores(), settings.max_running),  # every actor of the pool gets a CPU
            include_dashboard=False,
            log_to_driver=False,
        )


def make_ray_workers(
    settings: Settings, library: Library, warm: WarmUp = warm_up
) -> list[RayWorker]:
    """The pool's actors, once they have all started and warmed up (a mission then starts at
    once)."""
    import ray

    library_ref = ray.put(library)  # in the object store once, not per actor or mission
    workers = [RayWorker(i, library_ref, settings, warm) for i in range(settings.max_running)]
    try:
        ray.get([w.started for w in workers], timeout=CALL_SECONDS)
    except ray.exceptions.GetTimeoutError:  # e.g. a cluster still scaling up: missions wait
        log.warning("Ray actors not all started after %g s; missions wait for them", CALL_SECONDS)
    return workers


class RayWorker:
    """One slot of the pool as a Ray actor (``app.service.pool.Worker``)."""

    def __init__(
        self, index: int, library_ref: Any, settings: Settings, warm: WarmUp | None = warm_up
    ) -> None:
        import ray

        self.ray = ray
        self.index, self.settings = index, settings
        self.library_ref = library_ref  # the library in Ray's object store
        self.warm_up = warm if settings.warm_up else None
        self.remote: Any = ray.remote(MissionActor)
        self.lost = False
        self.pending: Any = None  # an unanswered poll: its messages must not be lost
        self.warmed: Any = None  # the ``started`` answer of the actor last seen warm
        self.rss_asked: Any = None  # an unanswered ``rss`` call
        self.rss_seen: int | None = None  # the actor's RSS as last answered
        self._spawn()

    def _spawn(self) -> None:
        settings = self.settings
        self.actor = self.remote.options(num_cpus=1, max_concurrency=4, max_restarts=0).remote(
            self.library_ref,
            settings.ws_rate,
            settings.worker_nice,
            self.warm_up,
            settings.worker_memory_bytes,
        )
        # Answered once the constructor (the warm-up) has run: this actor is warm from then on.
        self.started: Any = self.actor.ready.remote()
        self.lost, self.pending = False, None
        self.rss_asked, self.rss_seen = None, None

    def begin(self, job: Job) -> None:
        try:
            self.pid = self.ray.get(self.actor.begin.remote(job), timeout=CALL_SECONDS)
        except (self.ray.exceptions.RayError, TimeoutError) as exc:
            self.lost = True
            raise WorkerLost(f"Ray actor lost ({type(exc).__name__})") from exc

    def messages(self, timeout: float) -> list[WorkerMessage]:
        if self.pending is None:
            self.pending = self.actor.poll.remote(timeout)
        try:
            batch: list[WorkerMessage] = self.ray.get(self.pending, timeout=timeout + POLL_SLACK)
        except self.ray.exceptions.GetTimeoutError:
            return []  # still busy: the same poll is waited on next time
        except self.ray.exceptions.RayError as exc:
            self.lost = True
            raise WorkerLost(f"Ray actor lost ({type(exc).__name__})") from exc
        self.pending = None
        return batch

    def cancel(self) -> None:
        self.actor.cancel.remote()

    def update(self, mission_id: str, update: Update) -> None:
        self.actor.update.remote(Addressed(mission_id, update))

    def alive(self) -> bool:
        return not self.lost

    def memory(self) -> int | None:
        """The actor's RSS as last answered; asks again (an actor call, never waited on)."""
        asked = self.rss_asked
        if asked is not None:
            done, _ = self.ray.wait([asked], timeout=0)
            if not done:
                return self.rss_seen
            with contextlib.suppress(self.ray.exceptions.RayError):
                self.rss_seen = self.ray.get(asked, timeout=0)
        self.rss_asked = self.actor.rss.remote()
        return self.rss_seen

    def warm(self) -> bool:
        started = self.started  # this actor's, even if a restart (another thread) swaps it
        if self.lost:
            return False
        if self.warmed is started:
            return True
        done, _ = self.ray.wait([started], timeout=0)  # a look, never a wait
        if not done:
            return False
        try:
            self.ray.get(started, timeout=0)
        except self.ray.exceptions.RayError:  # it died in its constructor: gone, not warm
            if started is self.started:
                self.lost = True
            return False
        self.warmed = started  # remembered per actor: its replacement starts cold
        return started is self.started

    def restart(self) -> None:
        self._kill()
        self._spawn()

    def stop(self, timeout: float = 0.0) -> None:
        self._kill()

    def _kill(self) -> None:
        self.lost = True  # neither alive nor warm while it goes (and until its successor runs)
        with contextlib.suppress(Exception):  # already gone (or Ray is shutting down)
            self.ray.kill(self.actor, no_restart=True)

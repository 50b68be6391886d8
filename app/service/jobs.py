"""Learning jobs: one primitive, or a shape's whole lattice set (which joins the library as
a new version), learned in the background, with progress and cancellation."""

from __future__ import annotations

import logging
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from typing import Any

from app.service.library import SharedLibrary
from app.service.metrics import Metrics
from app.store.repo import Store
from primitives.learners import CancelledError, StopRule, UpdateRecord, make_learner
from primitives.params import ParameterSpace
from primitives.shape_learning import LearningCancelled, LearningStopped, learn_shape
from primitives.shapes import learned_name
from primitives.task import LearningTask

PROGRESS_SECONDS = 0.2


class JobsFull(Exception):
    """More learning jobs wait than ``max_queued`` allows (a 503 with Retry-After)."""


class Jobs:
    """Learning jobs, one at a time (``workers``); at most ``max_queued`` wait (the count is
    kept here, where the queue is, and checked with the job's creation under one lock)."""

    def __init__(
        self,
        store: Store,
        metrics: Metrics,
        workers: int = 1,
        max_queued: int = 16,
        library: SharedLibrary | None = None,
        budget: float = 30.0,
    ) -> None:
        self.store, self.metrics, self.max_queued = store, metrics, max_queued
        self.library, self.budget = library, budget
        self.pool = ThreadPoolExecutor(workers, thread_name_prefix="learn")
        self.cancels: dict[str, threading.Event] = {}
        self.waiting: set[str] = set()  # queued, not started yet
        self.lock = threading.Lock()

    def start(self, request: dict[str, Any]) -> str:
        """Store and queue a job; ``JobsFull`` (nothing stored) when too many wait."""
        with self.lock:
            if len(self.waiting) >= self.max_queued:
                raise JobsFull()
            row = self.store.create_job("learn", request)
            self.waiting.add(row.id)
        self.cancels[row.id] = threading.Event()
        self.pool.submit(self._run, row.id, request)
        return row.id

    def cancel(self, job_id: str) -> bool:
        row = self.store.get_job(job_id)
        if row is None or row.status in ("succeeded", "failed", "cancelled"):
            return False
        self.cancels.setdefault(job_id, threading.Event()).set()
        if row.status == "queued":
            with self.lock:
                self.waiting.discard(job_id)
            self.store.update_job(job_id, status="cancelled", reason="cancelled before it started")
        return True

    def stop(self) -> None:
        for event in self.cancels.values():
            event.set()
        self.pool.shutdown(wait=True)

    def _run(self, job_id: str, request: dict[str, Any]) -> None:
        with self.lock:
            self.waiting.discard(job_id)
        cancel = self.cancels[job_id]
        if cancel.is_set():
            return
        self.store.update_job(job_id, status="running")
        if request.get("joints") is not None:
            self._learn_shape(job_id, request["joints"], cancel)
            return
        space = ParameterSpace.for_shape(request["shape"])
        goal = (float(request["goal"][0]), float(request["goal"][1]))
        task = LearningTask(goal, space)
        stop = StopRule(request["threshold"], request["max_updates"])
        last = [0.0]

        def progress(rec: UpdateRecord) -> None:
            if cancel.is_set():
                raise CancelledError()
            if time.perf_counter() - last[0] >= PROGRESS_SECONDS:
                last[0] = time.perf_counter()
                self.store.update_job(
                    job_id,
                    progress={"update": rec.update, "cost": rec.cost, "rollouts": rec.rollouts},
                )

        try:
            result = make_learner(request["learner"]).learn(
                task, request["seed"], stop, progress=progress
            )
        except CancelledError:
            self.store.update_job(job_id, status="cancelled", reason="cancelled by request")
            self.metrics.jobs.labels("cancelled").inc()
            return
        except Exception as exc:  # record it: a job always ends with a reason
            # A ValueError explains the request; anything else may name server paths.
            why = f": {exc}" if isinstance(exc, ValueError) else " (see the server log)"
            logging.getLogger("screwsnake.jobs").exception("job %s failed", job_id)
            self.store.update_job(job_id, status="failed", reason=f"{type(exc).__name__}{why}")
            self.metrics.jobs.labels("failed").inc()
            return
        theta, joints, phases = space.split(result.params)
        summary = {
            "theta": theta,
            "joints": joints,
            "phases": phases,
            "cost": result.cost,
            "converged": result.converged,
            "updates": result.updates,
            "rollouts": result.rollouts,
            "curve": result.curve,
            "learner": result.learner,
            "seed": result.seed,
        }
        status = "succeeded" if result.converged else "failed"
        reason = (
            ""
            if result.converged
            else f"did not reach {stop.threshold} m in {stop.max_updates} updates"
        )
        progress_now = {"update": result.updates, "cost": result.cost, "rollouts": result.rollouts}
        self.store.update_job(
            job_id, status=status, reason=reason, result=summary, progress=progress_now
        )
        self.metrics.jobs.labels(status).inc()

    def _learn_shape(self, job_id: str, joints: list[float], cancel: threading.Event) -> None:
        """A shape's lattice set, into the library (unless that shape is there already)."""
        name = learned_name(joints)
        library = self.library
        if library is not None and name in library.library.lattice_shapes():
            result = {"shape": name, "learned": False, "library": library.version}
            self.store.update_job(
                job_id, status="succeeded", reason="the library has this shape", result=result
            )
            self.metrics.jobs.labels("succeeded").inc()
            return
        last = [0.0]

        def progress(done: int, total: int) -> None:
            if time.perf_counter() - last[0] >= PROGRESS_SECONDS or done == total:
                last[0] = time.perf_counter()
                self.store.update_job(job_id, progress={"done": done, "total": total})

        try:
            learned = learn_shape(
                joints, budget=self.budget, cancelled=cancel.is_set, progress=progress
            )
        except LearningCancelled:
            self.store.update_job(job_id, status="cancelled", reason="cancelled by request")
            self.metrics.jobs.labels("cancelled").inc()
            return
        except LearningStopped as exc:
            self.store.update_job(job_id, status="failed", reason=f"learning: {exc}")
            self.metrics.jobs.labels("failed").inc()
            return
        summary: dict[str, Any] = {**learned.summary(), "learned": True}
        if library is not None and learned.entries:
            stored, now = library.add(name, learned.entries, {"job_id": job_id})
            summary |= {"learned": stored, "library": now.version[:12]}
        status = "succeeded" if learned.entries else "failed"
        reason = "" if learned.entries else f"shape {name}: no lattice motion reached the bar"
        self.store.update_job(job_id, status=status, reason=reason, result=summary)
        self.metrics.jobs.labels(status).inc()

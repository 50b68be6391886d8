"""Mission intake: posted missions into the store and the queue, in batches.

A POST's store work (the insert, the commit, the queueing) runs in a thread, off the event loop.
One thread hop and one transaction per POST made a burst of posts a queue of hops, each a wait
for a thread and the GIL behind the others (20 posts at once took ~100 ms for the
last). Here the posts that arrive while a batch is being written wait together for the next
one: a burst costs a few hops and transactions, a lone post the same one hop as before. The
store stays the source of truth: a mission is queued only once its row is committed, and an
answer is sent only for a committed mission.

A retried Idempotency-Key is answered with its mission before the queue is looked at: a client
whose post was acknowledged gets it again (200) even while the queue is full; only new
missions beyond ``max_queued`` are refused (``QueueFull``: 503), and nothing is stored for them.
"""

from __future__ import annotations

import asyncio
import contextvars
import time
from typing import Any

from anyio import to_thread

from app import timing
from app.service.metrics import Metrics
from app.service.supervisor import QueueFull, Supervisor
from app.store.models import MissionRow
from app.store.repo import NewMission, Store

Created = tuple[MissionRow, bool]


class Intake:
    """Stores and queues posted missions, a batch (at most ``batch`` missions) at a time."""

    def __init__(
        self, store: Store, supervisor: Supervisor, metrics: Metrics, batch: int = 50
    ) -> None:
        self.store, self.supervisor, self.metrics, self.batch = store, supervisor, metrics, batch
        self.pending: list[tuple[NewMission, asyncio.Future[Created], timing.Timings | None]] = []
        self.writer: asyncio.Task[None] | None = None  # drains ``pending`` while it has any

    async def create(
        self, name: str, request: dict[str, Any], idempotency_key: str | None
    ) -> Created:
        """Store a mission (queued) and queue it, with whatever else is posted meanwhile;
        ``(row, False)`` for a retried Idempotency-Key (nothing new stored or queued)."""
        loop = asyncio.get_running_loop()
        done: asyncio.Future[Created] = loop.create_future()
        self.pending.append(((name, request, idempotency_key), done, timing.current.get()))
        if self.writer is None:
            # A context of its own: the writer outlives this request and serves others.
            self.writer = loop.create_task(self._drain(), context=contextvars.Context())
        return await done

    async def _drain(self) -> None:
        try:
            while self.pending:
                batch, self.pending = self.pending[: self.batch], self.pending[self.batch :]
                items = [item for item, _, _ in batch]
                t0 = time.perf_counter()
                spans = timing.Timings()  # the batch's own: its wait for the lock, its write
                try:
                    results = await to_thread.run_sync(self._write, items, spans)
                except Exception as exc:  # e.g. the database is down: each post answers it
                    for _, done, _ in batch:
                        if not done.done():
                            done.set_exception(exc)
                    continue
                ms = (time.perf_counter() - t0) * 1e3
                for (_, done, timings), result in zip(batch, results, strict=True):
                    if timings is not None:  # the request's Server-Timing: its batch's
                        timings.add("batch", ms)  # hop and transaction, and within it
                        for name, span_ms in spans.spans:  # the lock's wait and the write
                            timings.add(f"batch.{name}", span_ms)
                    if done.done():  # a client gone meanwhile: its mission runs anyway
                        continue
                    if result is None:
                        done.set_exception(QueueFull())
                    else:
                        done.set_result(result)
                    # One post answered per turn of the event loop: a batch of large missions
                    # (each answer is its whole request, serialized) would otherwise hold the
                    # loop for all of their answers at once, and every other request with it.
                    await asyncio.sleep(0)
        finally:
            self.writer = None

    def _write(self, items: list[NewMission], spans: timing.Timings) -> list[Created | None]:
        """In a thread: replays first, then as many new missions as the queue has room for
        (None for the others), in one transaction; then each new mission queued (the store's
        spans go to ``spans``)."""
        replays = self.store.missions_by_key([key for _, _, key in items if key])
        room = self.supervisor.room()
        admitted: list[int] = []  # indices into items: replays, then new ones while room lasts
        keys = set(replays)  # a key already used, or used earlier in this batch
        for i, (_, _, key) in enumerate(items):
            replay = bool(key) and key in keys
            if replay or room > 0:
                admitted.append(i)
                room -= 0 if replay else 1
                if key:
                    keys.add(key)
        token = timing.current.set(spans)
        try:
            stored = self.store.create_missions([items[i] for i in admitted]) if admitted else []
        finally:
            timing.current.reset(token)
        results: list[Created | None] = [None] * len(items)
        for i, (row, created) in zip(admitted, stored, strict=True):
            results[i] = (row, created)
            if created:
                self.metrics.created.inc()
                self.supervisor.submit(row.id, force=True)
        return results

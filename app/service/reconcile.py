"""Reconciliation: every mission the store calls active has a worker, every queued one a place
in the queue. Run at start-up (after ``interrupt_unfinished``) and periodically, it ends missions
whose worker is gone ``failed`` with a reason and re-queues queued missions the server lost."""

from __future__ import annotations

import logging
from datetime import timedelta
from typing import TYPE_CHECKING

from app.store.repo import Store, now

if TYPE_CHECKING:
    from app.service.supervisor import Supervisor

log = logging.getLogger("screwsnake.reconcile")
SETTLE = timedelta(seconds=10)  # a row this new may still be on its way into the queue
LOST = "worker lost: no worker process runs this mission any more (ended by reconciliation)"


def reconcile(store: Store, supervisor: Supervisor) -> list[str]:
    """End active missions that no worker runs; re-queue stranded queued ones. Returns the
    ids that were ended."""
    ended = []
    for mission_id in store.active():
        with supervisor.lock:
            if mission_id in supervisor.running:
                continue
            if store.transition(mission_id, "failed", LOST):
                ended.append(mission_id)
        log.warning("mission %s had no worker: failed", mission_id)
        supervisor.metrics.finished.labels("failed").inc()
        supervisor.publish_end(mission_id)
    with supervisor.lock:  # waiting, or started (its worker may not have said so yet)
        known = supervisor.known | supervisor.running
    for mission_id in store.queued(before=now() - SETTLE):
        if mission_id not in known:
            log.warning("mission %s was queued but not waiting: queued again", mission_id)
            supervisor.submit(mission_id, force=True)
    return ended

"""Reconciliation: every mission the store calls active has a worker, every queued one a place
in the queue. Run at start-up (after ``interrupt_unfinished``) and periodically, it ends missions
whose worker is gone ``failed`` with a reason and re-queues queued missions the server lost. A
mission whose end could not be written (a database fault) ends with the reason it had then
(``database error: ...``), not as a lost worker."""

from __future__ import annotations

import logging
from datetime import timedelta
from typing import TYPE_CHECKING

from app.missions.status import MissionStatus
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
            status, reason = supervisor.unended.get(mission_id, (MissionStatus.FAILED, LOST))
            written = store.transition(mission_id, status, reason)
            supervisor.unended.pop(mission_id, None)  # written (or ended meanwhile)
        if not written:
            continue
        ended.append(mission_id)
        log.warning("mission %s had no worker: %s (%s)", mission_id, status, reason)
        supervisor.metrics.finished.labels(status).inc()
        supervisor.publish_end(mission_id)
    with supervisor.lock:  # waiting, or started (its worker may not have said so yet)
        known = supervisor.known | supervisor.running
    for mission_id in store.queued(before=now() - SETTLE):
        if mission_id not in known:
            log.warning("mission %s was queued but not waiting: queued again", mission_id)
            supervisor.submit(mission_id, force=True)
    return ended

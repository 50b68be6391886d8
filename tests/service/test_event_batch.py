"""A worker sends a stretch of ticks' event frames as one message, in the order they came."""

from __future__ import annotations

import json
import threading
from pathlib import Path
from typing import Any

from app.missions.status import MissionStatus
from app.service import worker
from app.service.messages import Ended, Events, Job, Publish, WorkerMessage, frames_of
from primitives.library import load_bundled

HIDDEN = Path(__file__).parents[2] / "examples" / "untuned" / "eight-unordered-12m-hidden.json"


class Outbox(list[WorkerMessage]):
    def put(self, item: WorkerMessage) -> None:
        self.append(item)


def flattened(messages: list[WorkerMessage]) -> list[Any]:
    """Every event frame and every other message but the state frames (sent at a wall-clock
    rate), in order."""
    out: list[Any] = []
    for m in messages:
        if isinstance(m, Publish | Events):
            out += [("event", f["kind"], f["t"]) for f in frames_of(m) if f["type"] == "event"]
        else:
            out.append(type(m).__name__)
    return out


def test_event_frames_go_together_in_their_order() -> None:
    job = Job("m", json.loads(HIDDEN.read_text()), wall_limit=120)
    library = load_bundled()
    one_by_one, batched = Outbox(), Outbox()
    # without the batch: each event frame its own message
    worker._run(job, library, 10.0, one_by_one, threading.Event(), None)
    worker.run_mission(job, library, 10.0, batched, threading.Event())
    for out in (one_by_one, batched):
        assert isinstance(out[-1], Ended) and out[-1].status == MissionStatus.SUCCEEDED
    events = [e for e in flattened(one_by_one) if isinstance(e, tuple)]
    assert len(events) > 100  # obstacles sensed at many ticks, goals reached
    assert flattened(batched) == flattened(one_by_one)
    sent = [m for m in batched if isinstance(m, Events)]
    assert sent and sum(len(m.frames) for m in sent) == len(events)
    assert len(sent) < len(events) / 10  # a few messages for them all


def test_a_batch_waits_at_most_its_period(monkeypatch: Any) -> None:
    now = [0.0]
    monkeypatch.setattr(worker.time, "perf_counter", lambda: now[0])
    out = Outbox()
    batch = worker.EventBatch(out, 0.1)
    for t in range(5):  # ticks 0.03 s of wall apart, an event each
        batch.put(Publish({"type": "event", "t": float(t), "kind": "obstacle_sensed"}))
        batch.flush_due()
        now[0] += 0.03
    # the first four waited; at the fifth tick the oldest had waited 0.12 s
    assert [len(m.frames) for m in out if isinstance(m, Events)] == [5]
    batch.put(Publish({"type": "event", "t": 5.0, "kind": "goal_reached"}))
    batch.put(Publish({"type": "state", "t": 5.0}))  # anything else sends what is held first
    assert isinstance(out[-2], Events) and out[-2].frames[0]["kind"] == "goal_reached"
    assert isinstance(out[-1], Publish) and out[-1].frame["type"] == "state"

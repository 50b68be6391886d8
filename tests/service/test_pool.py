"""The warm worker pool: a worker runs missions one after another; a killed or hung worker is
replaced and its mission ends failed or cancelled with the reason; a queued mission starts as
soon as a worker frees. Which worker ran a mission is in its ``planning`` transition."""

from __future__ import annotations

import contextlib
import os
import re
import signal
from datetime import datetime
from pathlib import Path

from fastapi.testclient import TestClient

from tests.service.test_limits import GOAL, SLOW, app_client, wait_status

TERMINAL = ("succeeded", "failed", "cancelled")


def worker_pid(mission: dict) -> int:
    """The pid of the worker that ran the mission, as its ``planning`` transition says."""
    reasons = [t["reason"] for t in mission["transitions"] if t["status"] == "planning"]
    match = re.fullmatch(r"worker pid (\d+) on .+", reasons[0])
    assert match, reasons
    return int(match.group(1))


def seconds_between(mission: dict, first: str, then: str) -> float:
    at = {t["status"]: datetime.fromisoformat(t["at"]) for t in mission["transitions"]}
    return (at[then] - at[first]).total_seconds()


def run(c: TestClient, body: dict) -> dict:
    mission_id = c.post("/missions", json=body).json()["id"]
    return wait_status(c, mission_id, TERMINAL)


def test_one_worker_runs_missions_one_after_another(tmp_path: Path) -> None:
    with app_client(tmp_path, max_running=1) as c:
        first, second = run(c, GOAL), run(c, {**GOAL, "seed": 1})
        assert first["status"] == second["status"] == "succeeded"
        assert worker_pid(first) == worker_pid(second) != os.getpid()


def test_a_queued_mission_starts_when_the_worker_is_cancelled_free(tmp_path: Path) -> None:
    with app_client(tmp_path, max_running=1) as c:
        slow = c.post("/missions", json=SLOW).json()["id"]
        running = wait_status(c, slow, ("executing",))
        waiting = c.post("/missions", json=GOAL).json()["id"]
        assert wait_status(c, waiting, ("queued",))["status"] == "queued"
        assert c.post(f"/missions/{slow}/cancel").status_code == 202
        cancelled = wait_status(c, slow, TERMINAL)
        assert (cancelled["status"], cancelled["reason"]) == ("cancelled", "cancelled by request")
        assert seconds_between(cancelled, "cancelling", "cancelled") <= 1.0
        done = wait_status(c, waiting, TERMINAL)
        assert done["status"] == "succeeded", done["reason"]
        # it honoured the cancel: the same process, not a replacement, ran the next mission
        assert worker_pid(done) == worker_pid(running)


def test_a_killed_worker_is_replaced_and_its_mission_fails_with_the_reason(
    tmp_path: Path,
) -> None:
    with app_client(tmp_path, max_running=1) as c:
        slow = c.post("/missions", json=SLOW).json()["id"]
        pid = worker_pid(wait_status(c, slow, ("executing",)))
        os.kill(pid, signal.SIGKILL)
        m = wait_status(c, slow, TERMINAL, timeout=10)
        assert (m["status"], m["reason"]) == ("failed", "worker process died (exit code -9)")
        after = run(c, GOAL)
        assert after["status"] == "succeeded", after["reason"]
        assert worker_pid(after) != pid


def test_a_hung_worker_is_stopped_on_cancel_and_replaced(tmp_path: Path) -> None:
    with app_client(tmp_path, max_running=1) as c:
        slow = c.post("/missions", json=SLOW).json()["id"]
        pid = worker_pid(wait_status(c, slow, ("executing",)))
        os.kill(pid, signal.SIGSTOP)  # hangs: it can no longer honour a cancel
        try:
            assert c.post(f"/missions/{slow}/cancel").status_code == 202
            m = wait_status(c, slow, TERMINAL, timeout=10)
        finally:
            with contextlib.suppress(ProcessLookupError):  # it is killed by now
                os.kill(pid, signal.SIGCONT)
        assert (m["status"], m["reason"]) == ("cancelled", "cancelled by request")
        assert seconds_between(m, "cancelling", "cancelled") <= 1.0
        after = run(c, GOAL)
        assert after["status"] == "succeeded", after["reason"]
        assert worker_pid(after) != pid


def test_missions_beyond_the_pool_queue_and_all_finish(tmp_path: Path) -> None:
    with app_client(tmp_path, max_running=2) as c:
        ids = [c.post("/missions", json={**GOAL, "seed": k}).json()["id"] for k in range(5)]
        done = [wait_status(c, i, TERMINAL) for i in ids]
        assert [m["status"] for m in done] == ["succeeded"] * 5
        assert len({worker_pid(m) for m in done}) <= 2  # two warm processes did all the work

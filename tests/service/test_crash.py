"""SIGKILL the server in the middle of running missions, start it again: nothing is lost."""

from __future__ import annotations

import sqlite3
import time
from pathlib import Path

import httpx

from tests.service.test_server import start_server

QUICK = {
    "name": "quick",
    "goals": [{"x": -1, "y": -1}],
    "bounds": {"xmin": -5, "xmax": 5, "ymin": -5, "ymax": 5},
}
SLOW = {
    "name": "slow",
    "goals": [{"x": -4, "y": 4}],
    "bounds": {"xmin": -5, "xmax": 5, "ymin": -5, "ymax": 5},
    "speed": 1,
}


def survivors(marker: str) -> list[int]:
    """Processes whose environment names ``marker`` (the server and its workers inherit it)."""
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                if marker.encode() in (entry / "environ").read_bytes():
                    found.append(int(entry.name))
            except OSError:
                continue
    return found


def no_process_outlives(marker: str, timeout: float) -> bool:
    if not Path("/proc/self/environ").exists():
        return True  # not Linux: nothing to look at
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if not survivors(marker):
            return True
        time.sleep(0.2)
    return False


def wait_for(base: str, mission_id: str, statuses: tuple[str, ...], timeout: float = 60) -> dict:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        m = httpx.get(f"{base}/missions/{mission_id}", timeout=5).json()
        if m["status"] in statuses:
            return m
        time.sleep(0.05)
    raise AssertionError(f"{mission_id} never reached {statuses}")


def test_sigkill_mid_mission_then_restart(tmp_path: Path) -> None:
    db = tmp_path / "crash.db"
    proc, base = start_server(db, SCREWSNAKE_MAX_RUNNING="2")
    try:
        done = httpx.post(f"{base}/missions", json=QUICK, timeout=10).json()
        finished = wait_for(base, done["id"], ("succeeded",))
        slow = [
            httpx.post(f"{base}/missions", json=SLOW, timeout=10).json()["id"] for _ in range(3)
        ]
        wait_for(base, slow[0], ("executing",))
        wait_for(base, slow[1], ("executing",))
    finally:
        proc.kill()  # SIGKILL: no shutdown handlers run
        proc.wait(timeout=20)
    assert no_process_outlives(str(db), timeout=10), "a mission worker outlived its killed server"
    with sqlite3.connect(db) as conn:
        assert conn.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
    proc, base = start_server(db)
    try:
        after = httpx.get(f"{base}/missions/{done['id']}", timeout=10).json()
        assert after == finished  # finished missions are unchanged
        for mission_id in slow[:2]:  # acknowledged and running: failed, interrupted
            m = httpx.get(f"{base}/missions/{mission_id}", timeout=10).json()
            assert m["status"] == "failed" and m["reason"] == "interrupted"
            assert [t["status"] for t in m["transitions"]][-2:] == ["executing", "failed"]
        queued = httpx.get(
            f"{base}/missions/{slow[2]}", timeout=10
        ).json()  # acknowledged, never started
        assert queued["status"] in ("queued", "planning", "executing")  # it is picked up again
        httpx.post(f"{base}/missions/{slow[2]}/cancel", timeout=10)
        assert wait_for(base, slow[2], ("cancelled",))["status"] == "cancelled"
        assert httpx.get(f"{base}/missions", timeout=10).json()["total"] == 4
    finally:
        proc.terminate()
        proc.wait(timeout=20)
    with sqlite3.connect(db) as conn:
        assert conn.execute("PRAGMA integrity_check").fetchone()[0] == "ok"

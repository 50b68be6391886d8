"""Reliability against a real uvicorn server: auth and size checked before the body is read,
cancel honoured within a second in every state, the library kept in memory, the auth policy
and the allowed origins on HTTP and the websocket."""

from __future__ import annotations

import json
import shutil
import socket
import time
from collections.abc import Iterator
from datetime import datetime
from pathlib import Path

import httpx
import pytest
from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect

from primitives.library import bundled_library_path
from tests.service.test_crash import wait_for
from tests.service.test_readiness import wait_ready
from tests.service.test_server import start_server

KEY = "s3cret"
AUTH = {"Authorization": f"Bearer {KEY}"}
BOUNDS = {"xmin": -5, "xmax": 5, "ymin": -5, "ymax": 5}
GOAL = {"name": "rel", "goals": [{"x": -2, "y": 1}], "bounds": BOUNDS, "speed": 100}
SLOW = {"name": "slow", "goals": [{"x": -4, "y": 4}], "bounds": BOUNDS, "speed": 1}
# 50 unordered goals with pyperplan's A*/hFF: preparing the plan takes many seconds.
HEAVY = {
    "name": "heavy",
    "goals": [{"x": -18 + (i % 10) * 4, "y": -18 + (i // 10) * 8} for i in range(50)],
    "order": "any",
    "bounds": {"xmin": -20, "xmax": 20, "ymin": -20, "ymax": 20},
    "planner": {"search": "astar", "heuristic": "hff", "time_limit": 120},
}
TERMINAL = ("succeeded", "failed", "cancelled")


@pytest.fixture
def keyed(tmp_path: Path) -> Iterator[str]:
    proc, base = start_server(
        tmp_path / "keyed.db", SCREWSNAKE_API_KEY=KEY, SCREWSNAKE_MAX_BODY="100000"
    )
    yield base
    proc.terminate()
    proc.wait(timeout=20)


def raw_post(base: str, head: list[str], body: bytes = b"") -> tuple[int, float]:
    """Send a request's head (and maybe part of a body) on a socket: (status, seconds)."""
    host, port = base.removeprefix("http://").split(":")
    started = time.monotonic()
    with socket.create_connection((host, int(port)), timeout=10) as s:
        s.sendall(
            ("\r\n".join(["POST /missions HTTP/1.1", f"Host: {host}", *head]) + "\r\n\r\n").encode()
        )
        if body:
            s.sendall(body)
        status = int(s.recv(4096).split(b" ", 2)[1])
    return status, time.monotonic() - started


def test_auth_and_size_are_checked_before_the_body_is_read(keyed: str) -> None:
    # A 52 MB upload announced, not one byte sent: the answer comes without waiting for it.
    big = ["Content-Type: application/json", "Content-Length: 52000000"]
    status, took = raw_post(keyed, big)
    assert status == 401 and took < 5
    status, took = raw_post(keyed, [*big, f"Authorization: Bearer {KEY}"])
    assert status == 413 and took < 5
    # Streamed without a length: counted as it arrives, refused past the limit.
    chunks = (b" " * 10_000 for _ in range(50))
    r = httpx.post(f"{keyed}/missions", content=chunks, headers=AUTH, timeout=10)
    assert r.status_code == 413 and r.headers["content-type"] == "application/problem+json"
    assert httpx.get(f"{keyed}/missions", timeout=10).json()["total"] == 0
    r = httpx.post(f"{keyed}/missions", json=GOAL, headers=AUTH, timeout=10)
    assert r.status_code == 201


def cancel_took(base: str, mission_id: str) -> float:
    """Seconds between the cancel request and the terminal state, by the server's clock."""
    m = wait_for(base, mission_id, TERMINAL, timeout=30)
    assert m["status"] == "cancelled", m
    at = {t["status"]: datetime.fromisoformat(t["at"]) for t in m["transitions"]}
    asked = at.get("cancelling", at["cancelled"])
    return (at["cancelled"] - asked).total_seconds()


def test_cancel_is_honoured_within_a_second_in_every_state(tmp_path: Path) -> None:
    proc, base = start_server(tmp_path / "cancel.db", SCREWSNAKE_MAX_RUNNING="2")
    try:
        heavy = httpx.post(f"{base}/missions", json=HEAVY, timeout=10).json()["id"]
        slow = httpx.post(f"{base}/missions", json=SLOW, timeout=10).json()["id"]
        queued = httpx.post(f"{base}/missions", json=SLOW, timeout=10).json()["id"]
        wait_for(base, heavy, ("planning",))
        wait_for(base, slow, ("executing",))
        time.sleep(1.0)  # well inside the heavy mission's planning
        assert wait_for(base, heavy, ("planning",))["status"] == "planning"
        for mission_id in (queued, heavy, slow):
            r = httpx.post(f"{base}/missions/{mission_id}/cancel", timeout=10)
            assert r.status_code == 202
        for mission_id in (queued, heavy, slow):
            assert cancel_took(base, mission_id) <= 1.0
    finally:
        proc.terminate()
        proc.wait(timeout=20)


def test_the_library_is_kept_in_memory_after_start_up(tmp_path: Path) -> None:
    copy = tmp_path / "library.json"
    shutil.copy(bundled_library_path(), copy)
    proc, base = start_server(tmp_path / "lib.db", SCREWSNAKE_LIBRARY=str(copy))
    try:
        copy.unlink()  # the operator deletes (or replaces) the file
        ids = [httpx.post(f"{base}/missions", json=GOAL, timeout=10).json()["id"] for _ in range(2)]
        for mission_id in ids:
            m = wait_for(base, mission_id, TERMINAL)
            assert m["status"] == "succeeded", m["reason"]
        ready = httpx.get(f"{base}/readyz", timeout=10)
        assert ready.status_code == 200 and str(tmp_path) not in ready.text
    finally:
        proc.terminate()
        proc.wait(timeout=20)


def ws_url(base: str, mission_id: str, query: str = "") -> str:
    return base.replace("http", "ws") + f"/missions/{mission_id}/ws{query}"


def ws_frames(url: str, **kwargs: object) -> list[dict]:
    out = []
    with connect(url, open_timeout=10, **kwargs) as ws:  # type: ignore[arg-type]
        while True:
            frame = json.loads(ws.recv(timeout=60))
            out.append(frame)
            if frame["type"] == "end":
                return out


def test_auth_all_guards_reads_websocket_and_simulate(tmp_path: Path) -> None:
    proc, base = start_server(
        tmp_path / "all.db",
        SCREWSNAKE_API_KEY=KEY,
        SCREWSNAKE_AUTH="all",
        SCREWSNAKE_ALLOWED_ORIGINS="https://ops.example",
    )
    try:
        assert httpx.get(f"{base}/livez", timeout=10).status_code == 200  # probes stay open
        ready = wait_ready(lambda path: httpx.get(f"{base}{path}", timeout=10))
        assert ready.status_code == 200
        mission_id = httpx.post(f"{base}/missions", json=GOAL, headers=AUTH, timeout=10).json()[
            "id"
        ]
        assert httpx.get(f"{base}/missions", timeout=10).status_code == 401
        assert httpx.get(f"{base}/missions/{mission_id}", timeout=10).status_code == 401
        assert httpx.get(f"{base}/primitives", timeout=10).status_code == 401
        sim = {"theta": [-1, 1, -1, 1]}
        assert httpx.post(f"{base}/simulate", json=sim, timeout=10).status_code == 401
        assert httpx.post(f"{base}/simulate", json=sim, headers=AUTH, timeout=30).status_code == 200
        assert httpx.get(f"{base}/missions", headers=AUTH, timeout=10).status_code == 200
        with pytest.raises(InvalidStatus):
            ws_frames(ws_url(base, mission_id))
        with pytest.raises(InvalidStatus):  # right key, foreign origin
            ws_frames(
                ws_url(base, mission_id), additional_headers=AUTH, origin="https://evil.example"
            )
        frames = ws_frames(
            ws_url(base, mission_id), additional_headers=AUTH, origin="https://ops.example"
        )
        assert frames[0]["type"] == "snapshot" and frames[-1]["type"] == "end"
        frames = ws_frames(ws_url(base, mission_id, f"?token={KEY}"))  # browsers: no headers
        assert frames[-1]["status"] == "succeeded"
        # CORS: the allowed origin may call the API from a browser, others may not.
        pre = {"Origin": "https://ops.example", "Access-Control-Request-Method": "POST"}
        r = httpx.options(f"{base}/missions", headers=pre, timeout=10)
        assert r.headers.get("access-control-allow-origin") == "https://ops.example"
        r = httpx.options(
            f"{base}/missions", headers={**pre, "Origin": "https://evil.example"}, timeout=10
        )
        assert "access-control-allow-origin" not in r.headers
    finally:
        proc.terminate()
        proc.wait(timeout=20)


def test_auth_writes_leaves_reads_and_simulate_open(keyed: str) -> None:
    assert httpx.post(f"{keyed}/missions", json=GOAL, timeout=10).status_code == 401
    mission_id = httpx.post(f"{keyed}/missions", json=GOAL, headers=AUTH, timeout=10).json()["id"]
    assert httpx.get(f"{keyed}/missions/{mission_id}", timeout=10).status_code == 200
    sim = {"theta": [-1, 1, -1, 1]}
    assert httpx.post(f"{keyed}/simulate", json=sim, timeout=30).status_code == 200
    assert httpx.post(f"{keyed}/missions/{mission_id}/cancel", timeout=10).status_code == 401
    frames = ws_frames(ws_url(keyed, mission_id))  # no key needed to watch
    assert frames[-1]["type"] == "end"
    with pytest.raises(InvalidStatus):  # same-origin only, unless origins are allowed
        ws_frames(ws_url(keyed, mission_id), origin="https://evil.example")
    own = keyed  # the page served by this server opens the websocket: same origin
    assert ws_frames(ws_url(keyed, mission_id), origin=own)[-1]["type"] == "end"

"""A real uvicorn server on a free loopback port, an HTTP client and a websocket client."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
from websockets.sync.client import connect


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def start_server(db: Path, **env_extra: str) -> tuple[subprocess.Popen[bytes], str]:
    """uvicorn serving app.main:app on a free loopback port, once it answers /livez. Its
    workers skip the warm-up unless asked (``SCREWSNAKE_WARM_UP="1"``), as ``app_client``'s do:
    each warm-up costs seconds of CPU that the other tests running beside it would wait for."""
    port = free_port()
    env = {
        **os.environ,
        "SCREWSNAKE_DATABASE_URL": f"sqlite:///{db}",
        "SCREWSNAKE_WARM_UP": "0",
        **env_extra,
    }
    command = [
        sys.executable,
        "-m",
        "uvicorn",
        "app.main:app",
        "--host",
        "127.0.0.1",
        "--port",
        str(port),
        "--ws-per-message-deflate",  # off, as ``screwsnake serve`` serves by default
        "false",
    ]
    proc = subprocess.Popen(
        [*command, "--log-level", "warning"], env=env, cwd=Path(__file__).parents[2]
    )
    base = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        try:
            if httpx.get(f"{base}/livez", timeout=1).status_code == 200:
                return proc, base
        except httpx.HTTPError:
            time.sleep(0.1)
    proc.kill()
    raise AssertionError("server did not start")


@pytest.fixture
def server(tmp_path: Path) -> Iterator[str]:
    proc, base = start_server(tmp_path / "srv.db")
    yield base
    proc.terminate()
    proc.wait(timeout=20)


def test_real_server_http_and_websocket(server: str) -> None:
    body = {
        "name": "real",
        "goals": [{"x": -2, "y": 1}],
        "bounds": {"xmin": -5, "xmax": 5, "ymin": -5, "ymax": 5},
        "speed": 100,
    }
    r = httpx.post(f"{server}/missions", json=body, timeout=10)
    assert r.status_code == 201
    mission_id = r.json()["id"]
    frames = []
    with connect(
        server.replace("http", "ws") + f"/missions/{mission_id}/ws", open_timeout=10
    ) as ws:
        while True:
            frame = json.loads(ws.recv(timeout=60))
            frames.append(frame)
            if frame["type"] == "end":
                break
    types = [f["type"] for f in frames]
    assert types[0] == "snapshot" and types[-1] == "end" and "state" in types
    assert frames[-1]["status"] == "succeeded"
    states = [f for f in frames if f["type"] == "state"]
    assert {"t", "pose", "action", "sensors", "tree"} <= set(states[0])
    m = httpx.get(f"{server}/missions/{mission_id}", timeout=10).json()
    assert m["status"] == "succeeded" and m["goals"][0]["reached"]
    assert (
        httpx.post(
            f"{server}/missions", json={"goals": [{"x": "nan", "y": 0}]}, timeout=10
        ).status_code
        == 422
    )

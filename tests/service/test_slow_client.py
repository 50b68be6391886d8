"""A client that reads nothing does not change what the other clients get."""

from __future__ import annotations

import contextlib
import json
import threading
from pathlib import Path

import httpx
from websockets.sync.client import connect

from tests.service.test_server import start_server

MISSION = {
    "name": "paced",
    "goals": [{"x": -3, "y": -1}],
    "bounds": {"xmin": -5, "xmax": 5, "ymin": -5, "ymax": 5},
    "speed": 40,
}


def read_all(url: str, out: list[dict]) -> None:
    with connect(url, open_timeout=10, max_size=2**22) as ws:
        while True:
            frame = json.loads(ws.recv(timeout=60))
            out.append(frame)
            if frame["type"] == "end":
                return


def run(base: str, stalled: bool) -> list[dict]:
    mission_id = httpx.post(f"{base}/missions", json=MISSION, timeout=10).json()["id"]
    url = base.replace("http", "ws") + f"/missions/{mission_id}/ws"
    frames: list[dict] = []
    with contextlib.ExitStack() as stack:
        if stalled:
            stack.enter_context(connect(url, open_timeout=10))  # connected, never reads
        reader = threading.Thread(target=read_all, args=(url, frames))
        reader.start()
        reader.join(timeout=120)
    return frames


def test_a_stalled_client_does_not_slow_the_others(tmp_path: Path) -> None:
    proc, base = start_server(tmp_path / "slow.db", SCREWSNAKE_WS_RATE="50")
    try:
        baseline = run(base, stalled=False)
        with_sleeper = run(base, stalled=True)
    finally:
        proc.terminate()
        proc.wait(timeout=20)
    assert baseline[-1]["type"] == with_sleeper[-1]["type"] == "end"
    assert with_sleeper[-1]["status"] == "succeeded"
    states = [sum(f["type"] == "state" for f in frames) for frames in (baseline, with_sleeper)]
    assert states[0] > 20
    assert states[1] >= 0.7 * states[0], states

"""What the viewer loads for a finished mission: payload sizes and latencies of its endpoints.

Runs a few missions through the API (TestClient, SQLite in a temporary folder), then times
``GET /missions/{id}``, ``/replay``, ``/world`` and ``/plan`` (best of 5) and prints the JSON
sizes and how many trajectory rows, plan versions and events a replay carries. Never asserts.
"""

from __future__ import annotations

import json
import tempfile
import time
from pathlib import Path

from fastapi.testclient import TestClient

from app.main import create_app
from app.settings import Settings

ROOT = Path(__file__).parents[1]
MISSIONS = [
    "examples/cluttered-field.json",
    "examples/hard/six-unordered-hidden-clutter.json",
    "examples/hard/long-50m-four-goals.json",
]
ENDPOINTS = ("", "/replay", "/world", "/plan")


def wait_end(client: TestClient, mission_id: str, timeout: float = 600) -> dict[str, object]:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        m: dict[str, object] = client.get(f"/missions/{mission_id}").json()
        if m["status"] in ("succeeded", "failed", "cancelled"):
            return m
        time.sleep(0.2)
    raise TimeoutError(mission_id)


def best_ms(client: TestClient, path: str, repeat: int = 5) -> tuple[float, int]:
    best, size = float("inf"), 0
    for _ in range(repeat):
        start = time.perf_counter()
        r = client.get(path)
        best = min(best, time.perf_counter() - start)
        size = len(r.content)
    return best * 1e3, size


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        settings = Settings(database_url=f"sqlite:///{tmp}/bench.db", max_running=2)
        with TestClient(create_app(settings)) as client:
            ids = []
            for name in MISSIONS:
                body = json.loads((ROOT / name).read_text())
                body.pop("expect", None)
                ids.append((Path(name).stem, client.post("/missions", json=body).json()["id"]))
            print(f"{'mission':34} {'endpoint':9} {'ms':>7} {'KB':>8}  contents")
            for name, mission_id in ids:
                m = wait_end(client, mission_id)
                replay = client.get(f"/missions/{mission_id}/replay").json()
                world = client.get(f"/missions/{mission_id}/world").json()
                for endpoint in ENDPOINTS:
                    ms, size = best_ms(client, f"/missions/{mission_id}{endpoint}")
                    what = ""
                    if endpoint == "/replay":
                        what = (
                            f"{len(replay['trajectory'])} rows, {len(replay['plans'])} plans, "
                            f"{len(replay['events'])} events"
                        )
                    elif endpoint == "/world":
                        what = (
                            f"{len(world['sensed'])} sensed, {len(world['contacts'])} contact cells"
                        )
                    elif endpoint == "":
                        what = f"{m['status']}, {m['model_time']} model s"
                    print(f"{name:34} {endpoint or '/':9} {ms:7.1f} {size / 1024:8.1f}  {what}")


if __name__ == "__main__":
    main()

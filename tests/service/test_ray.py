"""Missions on Ray (``executor="ray"``), on a local Ray instance started once for this module:
a seeded mission ends exactly as on the local pool, frames reach the websocket, cancel works."""

from __future__ import annotations

import json
import os
import signal
from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from tests.service.test_limits import SLOW, app_client, wait_status
from tests.service.test_pool import TERMINAL, seconds_between, worker_pid
from tests.service.test_readiness import wait_ready

ray = pytest.importorskip("ray")
pytestmark = pytest.mark.xdist_group("ray")  # one local Ray instance at a time
EXAMPLE = json.loads(
    (Path(__file__).parents[2] / "examples" / "fig9a-single-goal.json").read_text()
)


@pytest.fixture(scope="module", autouse=True)
def local_ray() -> Iterator[None]:
    """One local instance for the module, started on the main thread: the apps attach to it
    (a TestClient's event loop thread, which would otherwise start it, ends with the client,
    and a local instance's processes end with the thread that started them)."""
    started = not ray.is_initialized()
    if started:
        ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield
    if started:
        ray.shutdown()


def outcome(c: TestClient, body: dict) -> dict:
    """What a user sees of a finished mission, minus ids and wall-clock times."""
    m = wait_status(c, c.post("/missions", json=body).json()["id"], TERMINAL, timeout=120)
    points = c.get(f"/missions/{m['id']}/trajectory").json()["points"]
    keep = ("status", "reason", "goals", "pose", "model_time", "collisions", "replans")
    return {k: m[k] for k in keep} | {"points": points, "worker": worker_pid(m)}


def test_a_mission_on_ray_ends_as_on_the_local_pool(tmp_path: Path) -> None:
    (tmp_path / "local").mkdir()
    (tmp_path / "ray").mkdir()
    with app_client(tmp_path / "local", max_running=1) as c:
        local = outcome(c, EXAMPLE)
    with app_client(tmp_path / "ray", max_running=1, executor="ray") as c:
        on_ray = outcome(c, EXAMPLE)
        frames = []
        mission_id = c.post("/missions", json={**EXAMPLE, "speed": 50}).json()["id"]
        with c.websocket_connect(f"/missions/{mission_id}/ws") as ws:
            while not frames or frames[-1]["type"] != "end":
                frames.append(ws.receive_json())
    assert local["status"] == "succeeded", local["reason"]
    assert on_ray.pop("worker") != local.pop("worker")  # a Ray worker process ran it
    assert on_ray == local
    types = [f["type"] for f in frames]
    assert types[0] == "snapshot" and "state" in types
    # the plan: in a plan frame, or in the snapshot when it was made before the client came
    assert "plan" in types or frames[0]["plan"]["version"] >= 1
    assert frames[-1]["status"] == "succeeded"


def test_cancel_stops_a_mission_running_on_ray(tmp_path: Path) -> None:
    with app_client(tmp_path, max_running=1, executor="ray") as c:
        mission_id = c.post("/missions", json=SLOW).json()["id"]
        wait_status(c, mission_id, ("executing",), timeout=120)
        assert c.post(f"/missions/{mission_id}/cancel").status_code == 202
        m = wait_status(c, mission_id, TERMINAL, timeout=10)
        assert (m["status"], m["reason"]) == ("cancelled", "cancelled by request")
        assert seconds_between(m, "cancelling", "cancelled") <= 1.0


def test_a_lost_ray_actor_is_replaced_and_its_mission_fails_with_the_reason(
    tmp_path: Path,
) -> None:
    with app_client(tmp_path, max_running=1, executor="ray") as c:
        mission_id = c.post("/missions", json=SLOW).json()["id"]
        pid = worker_pid(wait_status(c, mission_id, ("executing",), timeout=120))
        os.kill(pid, signal.SIGKILL)
        m = wait_status(c, mission_id, TERMINAL, timeout=60)
        assert m["status"] == "failed" and m["reason"].startswith("Ray actor lost"), m["reason"]
        after = wait_status(c, c.post("/missions", json=EXAMPLE).json()["id"], TERMINAL, 120)
        assert after["status"] == "succeeded", after["reason"]
        assert worker_pid(after) != pid


def test_a_ray_actor_is_warm_when_ready_and_its_replacement_starts_cold(tmp_path: Path) -> None:
    with app_client(tmp_path, max_running=1, executor="ray", warm_up=True) as c:
        ready = wait_ready(c.get)  # the pool starts once its actors have warmed up
        assert ready.json()["workers"] == {"warm": 1, "size": 1, "needed": 1}
        (worker,) = c.app.state.services.supervisor.workers  # type: ignore[attr-defined]
        worker.restart()  # a new actor: its constructor (the warm-up) has not run yet
        r = c.get("/readyz")
        assert r.status_code == 503 and r.json()["detail"] == "workers warming up (0/1 warm)"
        assert wait_ready(c.get).json()["workers"]["warm"] == 1

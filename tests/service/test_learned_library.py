"""Learned shapes through the service: a mission learns a shape, the entries join the library
as a new version in the database (GET /primitives lists them), later missions and workers run on
them, concurrent learners of one shape agree, a restart keeps the version, and POST /jobs/learn
learns a shape's lattice set."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

from fastapi.testclient import TestClient

from app.main import create_app
from app.settings import Settings
from tests.service.test_api import wait_end

START = {
    "name": "learn",
    "goals": [{"x": -2.5, "y": 1.0}],
    "bounds": {"xmin": -4, "xmax": 4, "ymin": -4, "ymax": 4},
    "obstacles": [{"type": "circle", "x": -1.3, "y": 0.5, "radius": 0.3, "known": False}],
    "seed": 1,
}
DEFORMED = [0.9, -0.3, 0.6]
LEARNED = "body-p090-m030-p060"


def app_client(tmp_path: Path, **settings: Any) -> TestClient:
    return TestClient(
        create_app(
            Settings(
                database_url=f"sqlite:///{tmp_path / 'learn.db'}",
                max_running=2,
                warm_up=False,
                **settings,
            )
        )
    )


def events(client: TestClient, mission_id: str) -> list[dict[str, Any]]:
    r = client.get(f"/missions/{mission_id}/events")
    assert r.status_code == 200
    lines = [json.loads(line) for line in r.text.splitlines() if line.strip()]
    return [e for e in lines if e["source"] == "mission"]


def wait_job(client: TestClient, job_id: str) -> dict[str, Any]:
    deadline = time.monotonic() + 60
    job = client.get(f"/jobs/{job_id}").json()
    while job["status"] in ("queued", "running") and time.monotonic() < deadline:
        time.sleep(0.05)
        job = client.get(f"/jobs/{job_id}").json()
    return job


def test_missions_learn_a_shape_once_and_the_next_mission_runs_on_it(tmp_path: Path) -> None:
    with app_client(tmp_path) as client:
        before = client.get("/primitives").json()["library"]
        deformed = {**START, "events": [{"t": 20, "type": "deform", "joints": DEFORMED}]}
        # two missions learning the same shape at once (one deformed into it, one starting in
        # it): each learns the same entries from the shape's seed, the store keeps them once
        ids = [
            client.post("/missions", json=deformed).json()["id"],
            client.post("/missions", json={**START, "shape": {"joints": DEFORMED}}).json()["id"],
        ]
        ends = [wait_end(client, i, timeout=120) for i in ids]
        assert [m["status"] for m in ends] == ["succeeded", "succeeded"], ends
        steps = [t["status"] for t in ends[0]["transitions"]]
        at = steps.index("learning")
        assert steps[at - 1 : at + 3] == ["executing", "learning", "replanning", "executing"]
        listed = client.get("/primitives", params={"shape": LEARNED}).json()
        assert listed["library"] != before and 0 < listed["count"] <= 22
        assert all(p["shape"] == LEARNED and p["family"] == "lattice" for p in listed["items"])
        learned = [[e for e in events(client, i) if e["kind"] == "learned"] for i in ids]
        assert learned[0] and learned[0][0]["shape"] == LEARNED and learned[0][0]["t"] == 20.0
        versions = {e["library"] for found in learned for e in found}
        assert versions == {listed["library"]}  # both ran on the version the service holds
        # a later mission starting in that shape (on a worker that started before it was
        # learned) learns nothing and reaches its goal
        later = client.post("/missions", json={**START, "shape": {"joints": DEFORMED}}).json()
        assert wait_end(client, later["id"], timeout=120)["status"] == "succeeded"
        assert not [e for e in events(client, later["id"]) if e["kind"] == "learned"]
        # outside the joint limits: 422 naming the field
        r = client.post("/missions", json={**START, "shape": {"joints": [1.55, 0.0, 0.0]}})
        assert r.status_code == 422 and "shape" in r.text and "joint limits" in r.text


def test_a_learning_job_and_a_restart_keep_the_library_version(tmp_path: Path) -> None:
    with app_client(tmp_path) as client:
        job = client.post("/jobs/learn", json={"joints": [-0.8, 0.4, -0.7]}).json()
        done = wait_job(client, job["id"])
        assert done["status"] == "succeeded" and done["result"]["learned"] is True
        assert done["progress"]["done"] == done["progress"]["total"] == 22
        version = client.get("/primitives").json()["library"]
        assert done["result"]["library"] == version
        again = wait_job(
            client, client.post("/jobs/learn", json={"joints": [-0.8, 0.4, -0.7]}).json()["id"]
        )
        assert again["status"] == "succeeded" and again["result"]["learned"] is False
        assert client.post("/jobs/learn", json={"joints": [0, 0, 1.55]}).status_code == 422
    # after a restart (a tiny learning budget now): the same version, the learned shape listed,
    # a mission in it learns nothing, and one needing a new shape fails naming it
    with app_client(tmp_path, learn_budget=0.001) as client:
        assert client.get("/primitives").json()["library"] == version
        shape = client.get("/primitives", params={"shape": "body-m080-p040-m070"}).json()
        assert shape["count"] == done["result"]["primitives"]
        known = client.post("/missions", json={**START, "shape": {"joints": [-0.8, 0.4, -0.7]}})
        assert wait_end(client, known.json()["id"], timeout=120)["status"] == "succeeded"
        new = client.post("/missions", json={**START, "shape": {"joints": DEFORMED}})
        end = wait_end(client, new.json()["id"], timeout=120)
        assert end["status"] == "failed"
        assert end["reason"].startswith(f"learning: shape {LEARNED}: not learned within")

"""The viewer's read endpoints: a mission's world model, its replay data, the static assets."""

from __future__ import annotations

import json
from pathlib import Path

from fastapi.testclient import TestClient

from tests.service.test_api import wait_end

EXAMPLES = Path(__file__).parents[2] / "examples"


def test_world_and_replay_of_a_finished_mission(client: TestClient) -> None:
    body = json.loads((EXAMPLES / "fig10-two-obstacles.json").read_text())  # hidden obstacles
    mission_id = client.post("/missions", json=body).json()["id"]
    m = wait_end(client, mission_id, timeout=120)
    assert m["status"] == "succeeded"

    world = client.get(f"/missions/{mission_id}/world").json()
    assert world["resolution"] == 0.05 and len(world["sensed"]) > 0
    assert all(len(cell) == 2 for cell in world["sensed"])

    replay = client.get(f"/missions/{mission_id}/replay").json()
    rows = replay["trajectory"]
    assert replay["status"] == "succeeded" and rows[0][0] == 0 and len(rows[0]) == 7
    assert abs(rows[-1][0] - m["model_time"]) < 1.0
    plans = replay["plans"]
    assert [p["version"] for p in plans] == list(range(1, len(plans) + 1))
    assert plans[0]["at"] == 0 and all(p["at"] is not None for p in plans)
    assert [p["at"] for p in plans] == sorted(p["at"] for p in plans)
    # Each replan made a plan version at its model time; events include them and the goal.
    assert [p["at"] for p in plans[1:]] == [r["at"] for r in replay["replans"]]
    kinds = {e["kind"] for e in replay["events"]}
    assert {"replan", "goal_reached"} <= kinds
    assert all(e["t"] <= m["model_time"] for e in replay["events"])


def test_viewer_endpoints_for_unknown_missions_and_assets(client: TestClient) -> None:
    for path in ("/missions/nope/world", "/missions/nope/replay"):
        r = client.get(path)
        assert r.status_code == 404 and r.headers["content-type"] == "application/problem+json"
    for name, kind in (
        ("viewer.js", "javascript"),
        ("map.js", "javascript"),
        ("viewer.css", "css"),
    ):
        r = client.get(f"/static/{name}")
        assert r.status_code == 200 and kind in r.headers["content-type"]
    assert client.get("/static/..%2Fmain.py").status_code == 404
    assert client.get("/static/index.html").status_code == 404  # served at / only

"""Live updates of a running mission: add and remove goals, add known obstacles, pause and
resume; each replans, shows in the transitions, on the websocket and in the event log."""

from __future__ import annotations

import json
import time
from collections.abc import Callable

from fastapi.testclient import TestClient

from tests.service.test_api import GOAL, wait_end

SLOW = {**GOAL, "speed": 10.0}  # paced: 10 model s per wall second, time to step in


def wait_for(client: TestClient, mission_id: str, ok: Callable[[dict], bool], timeout=60) -> dict:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        m = client.get(f"/missions/{mission_id}").json()
        if ok(m):
            return m
        assert m["status"] not in ("succeeded", "failed", "cancelled"), m["reason"]
        time.sleep(0.05)
    raise AssertionError(f"mission {mission_id}: condition not met")


def executing(m: dict) -> bool:
    return m["status"] == "executing" and m["model_time"] > 0


def test_a_goal_added_mid_mission_is_reached(client: TestClient) -> None:
    mission = client.post("/missions", json=SLOW).json()
    wait_for(client, mission["id"], executing)
    r = client.post(f"/missions/{mission['id']}/goals", json={"x": -1, "y": 1.5})
    assert r.status_code == 202, r.text
    assert r.json()["goal"] == 1 and r.json()["update"] == "add_goal"
    end = wait_end(client, mission["id"])
    assert end["status"] == "succeeded", end["reason"]
    assert [g["reached"] for g in end["goals"]] == [True, True]
    assert end["goals"][1]["x"] == -1 and end["goals"][1]["y"] == 1.5
    triggers = [
        r["trigger"] for r in client.get(f"/missions/{mission['id']}/plan").json()["replans"]
    ]
    assert "goals_changed" in triggers
    reasons = [(t["status"], t["reason"]) for t in end["transitions"]]
    assert ("replanning", "goals_changed") in reasons
    # the audit trail: transitions, then the mission's events, as JSON lines
    r = client.get(f"/missions/{mission['id']}/events")
    assert r.status_code == 200 and r.headers["content-type"].startswith("application/jsonl")
    lines = [json.loads(line) for line in r.text.splitlines()]
    assert lines[0] == {**lines[0], "source": "transition", "status": "queued"}
    updates = [e for e in lines if e.get("kind") == "update"]
    assert updates[0]["update"] == "add_goal" and updates[0]["detail"]["goal"] == 1
    kinds = [e.get("kind") for e in lines]
    assert kinds.count("goal_reached") == 2 and "replan" in kinds


def test_pause_stops_model_time_and_resume_goes_on(client: TestClient) -> None:
    mission = client.post("/missions", json=SLOW).json()
    wait_for(client, mission["id"], executing)
    assert client.post(f"/missions/{mission['id']}/pause").status_code == 202
    paused = wait_for(client, mission["id"], lambda m: m["status"] == "paused")
    time.sleep(1.0)  # 10 model seconds, were it running
    still = client.get(f"/missions/{mission['id']}").json()
    assert still["status"] == "paused" and still["model_time"] == paused["model_time"]
    assert still["pose"] == paused["pose"]
    again = client.post(f"/missions/{mission['id']}/pause")
    assert again.status_code == 409 and "already paused" in again.json()["detail"]
    assert client.post(f"/missions/{mission['id']}/resume").status_code == 202
    end = wait_end(client, mission["id"])
    assert end["status"] == "succeeded" and end["model_time"] > paused["model_time"]
    reasons = [(t["status"], t["reason"]) for t in end["transitions"]]
    at = reasons.index(("paused", "pause requested"))
    assert reasons[at + 1] == ("executing", "resumed")
    assert ("replanning", "resumed") in reasons[at + 1 :]
    r = client.post(f"/missions/{mission['id']}/resume")
    assert r.status_code == 409 and "already ended" in r.json()["detail"]


def test_goals_are_named_by_their_posted_index_and_a_reached_one_stays(
    client: TestClient,
) -> None:
    body = {**SLOW, "goals": [{"x": -0.8, "y": -0.4}, {"x": -2, "y": -1}, {"x": 2, "y": 2}]}
    mission = client.post("/missions", json=body).json()
    wait_for(client, mission["id"], lambda m: m["goals"][0]["reached"])
    r = client.delete(f"/missions/{mission['id']}/goals/0")
    assert r.status_code == 409 and "already reached" in r.json()["detail"]
    r = client.delete(f"/missions/{mission['id']}/goals/7")
    assert r.status_code == 404 and "no goal 7" in r.json()["detail"]
    assert client.delete(f"/missions/{mission['id']}/goals/2").status_code == 202
    end = wait_end(client, mission["id"])
    assert end["status"] == "succeeded", end["reason"]
    assert [(g["reached"], g["removed"]) for g in end["goals"]] == [
        (True, False),
        (True, False),
        (False, True),
    ]


def test_a_known_obstacle_added_mid_mission_is_planned_around(client: TestClient) -> None:
    mission = client.post("/missions", json={**GOAL, "speed": 6.0}).json()
    wait_for(client, mission["id"], executing)
    # beyond the goal, seen from the start: never where the robot is by the time it arrives
    wall = {"type": "rectangle", "x": -2.8, "y": -1.4, "width": 0.2, "height": 1.0, "angle": 0.5}
    r = client.post(f"/missions/{mission['id']}/obstacles", json={"obstacle": wall})
    assert r.status_code == 202, r.text
    end = wait_end(client, mission["id"])
    replans = client.get(f"/missions/{mission['id']}/plan").json()["replans"]
    added = [p for p in replans if p["trigger"] == "obstacle_added"]
    assert added, [p["trigger"] for p in replans]
    assert added[0]["detail"]["obstacle"]["type"] == "polygon"
    assert end["status"] == "succeeded", end["reason"]


def test_updates_are_409_once_a_mission_ended_and_422_for_bad_goals(client: TestClient) -> None:
    mission = client.post("/missions", json=GOAL).json()
    wait_end(client, mission["id"])
    for method, path, body in (
        ("post", "goals", {"x": 1, "y": 1}),
        ("delete", "goals/0", None),
        ("post", "obstacles", {"obstacle": {"type": "circle", "x": 1, "y": 1, "radius": 0.2}}),
        ("post", "pause", None),
        ("post", "resume", None),
    ):
        r = client.request(method, f"/missions/{mission['id']}/{path}", json=body)
        assert r.status_code == 409 and "already ended" in r.json()["detail"], path
    slow = client.post("/missions", json=SLOW).json()
    wait_for(client, slow["id"], executing)
    r = client.post(f"/missions/{slow['id']}/goals", json={"x": 50, "y": 0})
    assert r.status_code == 422 and "outside the bounds" in r.json()["detail"]
    r = client.post(f"/missions/{slow['id']}/goals", json={"x": "1", "y": 0})
    assert r.status_code == 422 and r.json()["field"] == "x"
    client.post(f"/missions/{slow['id']}/cancel")
    assert wait_end(client, slow["id"])["status"] == "cancelled"

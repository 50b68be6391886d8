"""What a mission knows and sensed, as the API lists it: the current goals and known obstacles
(posted or added live, with when and how they came), the world model at any replayed time, the
path of a running mission, and request bodies that say what they want."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from fastapi.testclient import TestClient

from app.executor.runner import MissionRunner
from app.executor.warm import WARM_UP
from app.missions.spec import MissionSpec
from app.service.world_history import WorldHistory, world_at
from primitives.library import load_bundled
from tests.service.test_api import GOAL, wait_end
from tests.service.test_live_updates import SLOW, executing, wait_for

EXAMPLES = Path(__file__).parents[2] / "examples"
POST = {"type": "circle", "x": 3.0, "y": 3.0, "radius": 0.2}


def test_goals_and_obstacles_added_live_are_listed_with_when_and_how(
    client: TestClient,
) -> None:
    hidden = {"type": "circle", "x": 2.0, "y": -3.0, "radius": 0.2, "known": False}
    # a far goal: the mission must still run after three updates on a slow, busy machine
    body = {**SLOW, "goals": [{"x": -4, "y": -4}], "obstacles": [hidden, POST]}
    mission = client.post("/missions", json=body).json()
    # before it runs: the posted goal and the posted known obstacle (the hidden one is not known)
    assert [o["id"] for o in mission["obstacles"]] == ["request-1"]
    assert mission["obstacles"][0] == {
        "id": "request-1",
        "source": "request",
        "added_at": 0.0,
        "obstacle": {**POST, "known": True},
    }
    assert mission["goals"][0]["source"] == "request"
    mission_id = mission["id"]
    wait_for(client, mission_id, executing)
    wall = {"type": "circle", "x": -3.0, "y": 2.5, "radius": 0.3}  # flat, as in a mission
    added = client.post(f"/missions/{mission_id}/obstacles", json=wall)
    assert added.status_code == 202, added.text
    goal_added = client.post(f"/missions/{mission_id}/goals", json={"x": -1, "y": 1.5})
    assert goal_added.status_code == 202, goal_added.text
    old_form = {"obstacle": {"type": "circle", "x": 3.5, "y": -3.5, "radius": 0.2}}
    assert client.post(f"/missions/{mission_id}/obstacles", json=old_form).status_code == 202

    m = wait_for(client, mission_id, lambda m: len(m["obstacles"]) == 3 and len(m["goals"]) == 2)
    live = m["obstacles"][1]
    assert live["id"] == "live-0" and live["source"] == "live" and live["added_at"] > 0
    assert live["obstacle"] == {**wall, "known": True}
    assert m["obstacles"][2]["id"] == "live-1" and m["obstacles"][2]["obstacle"]["x"] == 3.5
    goal = m["goals"][1]
    assert (goal["x"], goal["y"], goal["source"]) == (-1, 1.5, "live")
    assert 0 < goal["added_at"] <= m["model_time"]
    world = client.get(f"/missions/{mission_id}/world").json()  # the same lists
    assert [o["id"] for o in world["obstacles"]] == ["request-1", "live-0", "live-1"]
    assert [g["source"] for g in world["goals"]] == ["request", "live"]
    client.post(f"/missions/{mission_id}/cancel")
    end = wait_end(client, mission_id)
    # a replay at a time before the live ones came lists only those posted
    before = client.get(f"/missions/{mission_id}/world", params={"at": 0}).json()
    assert [o["id"] for o in before["obstacles"]] == ["request-1"] and len(before["goals"]) == 1
    replay = client.get(f"/missions/{mission_id}/replay").json()
    assert [o["id"] for o in replay["obstacles"]] == [o["id"] for o in end["obstacles"]]


def test_the_world_model_is_replayed_as_it_was_at_each_time(client: TestClient) -> None:
    body = json.loads((EXAMPLES / "cluttered-field.json").read_text())  # hidden obstacles
    mission_id = client.post("/missions", json=body).json()["id"]
    m = wait_end(client, mission_id, timeout=120)
    assert m["status"] == "succeeded", m["reason"]
    changes = client.get(f"/missions/{mission_id}/replay").json()["world"]
    assert len(changes) > 3 and [c["t"] for c in changes] == sorted(c["t"] for c in changes)
    first_seen = min(c["t"] for c in changes if c.get("sensed"))

    end = client.get(f"/missions/{mission_id}/world").json()
    replayed_end = client.get(f"/missions/{mission_id}/world", params={"at": 1e5}).json()
    assert sorted(map(tuple, replayed_end["sensed"])) == sorted(map(tuple, end["sensed"]))
    start = client.get(f"/missions/{mission_id}/world", params={"at": 0}).json()
    assert start["sensed"] == [] and start["model_time"] == 0  # nothing seen yet
    early = client.get(f"/missions/{mission_id}/world", params={"at": first_seen}).json()
    assert 0 < len(early["sensed"]) < len(end["sensed"])
    sensed_later = {tuple(c) for c in end["sensed"]} - {tuple(c) for c in early["sensed"]}
    assert sensed_later  # cells sensed after that time are not in the early world


def test_world_history_records_changes_only() -> None:
    class Model:
        def __init__(self) -> None:
            self.version, self.cells = 0, [[0.025, 0.025]]

        def to_dict(self) -> dict[str, Any]:
            return {"sensed": self.cells, "contact": []}

    model, history = Model(), WorldHistory()
    history.observe(0.0, model)
    history.observe(0.5, model)  # too soon, and unchanged
    model.version, model.cells = 1, [[0.075, 0.025]]
    history.observe(0.75, model)  # changed, but within a model second
    history.observe(1.0, model)
    model.version = 2
    history.observe(3.0, model)  # a new version with the same cells: no change recorded
    assert [c["t"] for c in history.changes] == [0.0, 1.0]
    assert history.changes[1]["sensed"] == {"added": [[0.075, 0.025]], "removed": [[0.025, 0.025]]}
    assert world_at(history.changes, 0.9)["sensed"] == [[0.025, 0.025]]
    assert world_at(history.changes, 2.0) == {"sensed": [[0.075, 0.025]], "contacts": []}


def test_world_history_reads_the_model_only_when_a_recorded_layer_changed() -> None:
    """The observed cells change at nearly every tick; the history records the sensed and
    contact cells, so only their versions make it read the model."""

    class Model:
        def __init__(self) -> None:
            self.version = self.contact_version = self.soft_version = self.reads = 0

        def to_dict(self) -> dict[str, Any]:
            self.reads += 1
            contact = [[0.125, 0.025]] if self.contact_version else []
            return {"sensed": [[0.025, 0.025]], "contact": contact}

    model, history = Model(), WorldHistory()
    for t in range(10):  # observed cells only, every model second
        model.soft_version += 1
        history.observe(float(t), model)
    assert model.reads == 1
    model.contact_version = 1
    history.observe(10.0, model)
    assert model.reads == 2
    assert history.changes[-1]["contacts"] == {"added": [[0.125, 0.025]], "removed": []}


def test_a_world_model_s_history_by_cell_index_is_the_one_its_to_dict_gives() -> None:
    """Comparing a world model's cell masks gives the same changes as diffing its ``to_dict``
    lists, tick by tick, through a mission that senses a hidden post and is touched."""

    class Listed:  # the same model, seen through to_dict only
        def __init__(self, world: Any) -> None:
            self.world = world

        @property
        def version(self) -> int:
            return int(self.world.version)

        @property
        def contact_version(self) -> int:
            return int(self.world.contact_version)

        def to_dict(self) -> dict[str, Any]:
            return dict(self.world.to_dict())

    runner = MissionRunner(MissionSpec.model_validate(WARM_UP), load_bundled())
    by_index, by_dict = WorldHistory(every=0.0), WorldHistory(every=0.0)
    ticks = 0
    while not runner.step():
        ctx, ticks = runner.ctx, ticks + 1
        if ticks in (10, 30):  # a touch reported on a unit's side: contact evidence comes
            ctx.world.add_contact(ctx.pose, ctx.sensed_joints(), 3, "left", ctx.t)
        by_index.observe(ctx.t, ctx.world)
        by_dict.observe(ctx.t, Listed(ctx.world))
    assert by_index.changes == by_dict.changes
    assert any("sensed" in c for c in by_index.changes)
    assert any(c.get("contacts", {}).get("added") for c in by_index.changes)


def test_a_running_missions_path_so_far(client: TestClient) -> None:
    mission_id = client.post("/missions", json=SLOW).json()["id"]
    wait_for(client, mission_id, lambda m: m["model_time"] > 3)
    rows = client.get(f"/missions/{mission_id}/trajectory").json()["points"]
    assert len(rows) >= 3 and rows[0][0] < 1 and all(len(r) == 7 for r in rows)
    assert [r[0] for r in rows] == sorted(r[0] for r in rows)
    client.post(f"/missions/{mission_id}/cancel")
    wait_end(client, mission_id)


def test_a_body_that_is_not_json_says_to_send_json(client: TestClient) -> None:
    cases = [
        (
            "name=x",
            "application/x-www-form-urlencoded",
            "came as application/x-www-form-urlencoded",
        ),
        (json.dumps(GOAL), "text/plain", "came as text/plain"),
        ("{bad", "application/json", "not valid JSON"),
        ("", None, "the body is empty"),
        ("[1, 2]", "application/json", "not a JSON object"),
    ]
    for content, media, why in cases:
        headers = {"Content-Type": media} if media else {}
        r = client.post("/missions", content=content, headers=headers)
        assert r.status_code == 422 and r.json()["field"] == "body", r.text
        detail = r.json()["detail"]
        assert detail.startswith("body: send JSON (application/json)") and why in detail, detail


def test_every_request_body_has_an_example(client: TestClient) -> None:
    spec = client.get("/openapi.json").json()
    bodies = 0
    for path, item in spec["paths"].items():
        for method, op in item.items():
            content = op.get("requestBody", {}).get("content", {})
            for media, entry in content.items():
                bodies += 1
                schema = entry.get("schema", {})
                ref = schema.get("$ref", "").rsplit("/", 1)[-1]
                component = spec["components"]["schemas"].get(ref, {})
                assert entry.get("examples") or entry.get("example") or component.get("examples"), (
                    f"{method.upper()} {path} ({media}) has no example"
                )
    assert bodies >= 5
    examples = spec["paths"]["/missions/{mission_id}/obstacles"]["post"]["requestBody"]
    shown = examples["content"]["application/json"]["examples"]
    assert {v["value"]["type"] for v in shown.values()} == {"circle", "rectangle", "polygon"}

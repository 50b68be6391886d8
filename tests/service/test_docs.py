"""The API documents itself: offline docs, described fields, declared errors, the websocket
protocol as AsyncAPI whose per-frame JSON Schemas the real frames satisfy."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import jsonschema
import pytest
from fastapi.testclient import TestClient

from app.executor.runner import MissionRunner
from app.missions.spec import load_mission
from app.service.frames import StateFrame, parse_frame
from primitives.library import Library, bundled_library_path
from tests.service.test_api import frames, wait_end

EXAMPLES = Path(__file__).parents[2] / "examples"


def test_docs_pages_load_their_assets_from_the_app_not_a_cdn(client: TestClient) -> None:
    for page in ("/docs", "/redoc"):
        html = client.get(page).text
        urls = re.findall(r'(?:src|href)="([^"]+)"', html) + re.findall(r"url: '([^']+)'", html)
        assert urls, page
        for url in urls:
            assert url.startswith("/"), f"{page} loads {url}"  # nothing from another host
            assert client.get(url).status_code == 200, url
        assert "fonts.googleapis" not in html


def test_every_field_and_parameter_is_described(client: TestClient) -> None:
    schema = client.get("/openapi.json").json()
    missing = []
    for name, component in schema["components"]["schemas"].items():
        for prop, spec in (component.get("properties") or {}).items():
            if not spec.get("description"):
                missing.append(f"{name}.{prop}")
    for path, item in schema["paths"].items():
        for method, op in item.items():
            for param in op.get("parameters", []):
                if not param.get("description"):
                    missing.append(f"{method} {path} {param['name']}")
    assert not missing
    # units are spelled out where they matter
    spec = schema["components"]["schemas"]
    assert "radians" in spec["Pose"]["properties"]["psi"]["description"]
    assert "metres" in spec["GoalSpec"]["properties"]["tolerance"]["description"]
    assert "model seconds" in spec["MissionSpec"]["properties"]["time_limit"]["description"]


def test_errors_are_declared_per_route_as_problem_json(client: TestClient) -> None:
    schema = client.get("/openapi.json").json()
    ops = schema["paths"]
    create = ops["/missions"]["post"]["responses"]
    assert {"200", "201", "401", "409", "422"} <= set(create)
    assert set(ops["/missions/{mission_id}/cancel"]["post"]["responses"]) >= {"401", "404", "409"}
    assert "404" in ops["/missions/{mission_id}/tree"]["get"]["responses"]
    assert "422" in ops["/primitives"]["get"]["responses"]
    for path, item in ops.items():
        for method, op in item.items():
            for code, answer in op["responses"].items():
                if code.startswith(("4", "5")):
                    assert list(answer["content"]) == ["application/problem+json"], (
                        f"{method} {path} {code}"
                    )
    assert "HTTPValidationError" not in schema["components"]["schemas"]


def test_request_examples_come_from_the_example_missions(client: TestClient) -> None:
    op = client.get("/openapi.json").json()["paths"]["/missions"]["post"]
    examples = op["requestBody"]["content"]["application/json"]["examples"]
    assert "fig9a-single-goal" in examples and len(examples) >= 4
    for name, example in examples.items():
        assert example["value"] == json.loads((EXAMPLES / f"{name}.json").read_text())


def frame_validators(client: TestClient) -> dict[tuple[str, str | None], Any]:
    """(type, event kind) -> a validator of that frame's JSON Schema from /asyncapi.json."""
    doc = client.get("/asyncapi.json").json()
    assert doc["asyncapi"].startswith("3.")
    components = doc["components"]["schemas"]
    out = {}
    for message in doc["components"]["messages"].values():
        name = message["payload"]["$ref"].rsplit("/", 1)[1]
        schema = {**components[name], "components": {"schemas": components}}
        props = schema["properties"]
        key = (props["type"]["const"], props.get("kind", {}).get("const"))
        out[key] = jsonschema.Draft202012Validator(schema)
    return out


def check_frames(validators: dict[tuple[str, str | None], Any], got: list[dict]) -> None:
    for frame in got:
        key = (frame["type"], frame.get("kind"))
        assert key in validators, f"undocumented frame {key}"
        validators[key].validate(frame)  # raises with the path of what breaks the schema


def test_real_frames_match_the_asyncapi_schemas_and_come_once_in_order(
    client: TestClient,
) -> None:
    validators = frame_validators(client)
    assert len(validators) >= 12
    body = json.loads((EXAMPLES / "fig13b-deformation.json").read_text())
    mission = client.post("/missions", json=body).json()
    got = frames(client, mission["id"])
    check_frames(validators, got)
    kinds = [(f["type"], f.get("kind"), f.get("status")) for f in got if f["type"] != "state"]
    replans = [f for f in got if f.get("kind") == "replan"]
    deforms = [f for f in got if f.get("kind") == "deform"]
    assert len(replans) == 1 and len(deforms) == 1, kinds  # each sent once
    assert replans[0]["trigger"] == "shape_changed" and replans[0]["version"] == 2
    # replanning (status), the replan, then its plan, then executing again
    at = kinds.index(("event", "status", "replanning"))
    assert kinds[at + 1] == ("event", "replan", "solved")
    assert kinds[at + 2][0] == "plan"
    assert kinds[at + 3] == ("event", "status", "executing")
    plan2 = next(f for f in got if f["type"] == "plan" and f["version"] == 2)
    assert got.index(plan2) > got.index(replans[0])
    # the client's own messages are answered by documented frames too
    with client.websocket_connect(f"/missions/{mission['id']}/ws") as ws:
        snapshot = ws.receive_json()
        end = ws.receive_json()
    check_frames(validators, [snapshot, end])
    with client.websocket_connect("/missions/nope/ws") as ws:
        check_frames(validators, [ws.receive_json()])


def test_a_finished_missions_tree_shows_how_it_ended(client: TestClient) -> None:
    body = json.loads((EXAMPLES / "fig9a-single-goal.json").read_text())
    mission = client.post("/missions", json=body).json()
    assert wait_end(client, mission["id"])["status"] == "succeeded"
    tree = client.get(f"/missions/{mission['id']}/tree").json()
    assert tree["name"] == "fig9a-single-goal" and tree["status"] == "SUCCESS"


@pytest.mark.parametrize(("max_points", "rows"), [(2000, 101), (11, 11), (2, 2), (7, 7)])
def test_simulate_thinning_is_a_parameter_and_said(
    client: TestClient, max_points: int, rows: int
) -> None:
    out = client.post(
        "/simulate", json={"theta": [-1, 1, -1, 1], "duration": 100, "max_points": max_points}
    ).json()
    assert len(out["points"]) == rows and out["steps"] == 100
    assert out["points"][-1][0] == 100  # the last step is always there
    assert out["points"][1][0] == out["stride"]  # dt = 1: row i is step i * stride


def test_every_event_and_state_a_mission_makes_is_a_protocol_frame() -> None:
    """What the worker publishes parses as the typed frames the hub carries (never dropped)."""
    library = Library.load(bundled_library_path())
    kinds = set()
    for name in ("fig9b-chain", "deform-while-avoiding", "hard/dropout-ir-hidden-wall"):
        runner = MissionRunner(load_mission(EXAMPLES / f"{name}.json"), library)
        while not runner.step():
            if int(runner.ctx.t * 4) % 40 == 0:
                state = parse_frame({"type": "state", **runner.snapshot()})
                assert isinstance(state, StateFrame)
        for event in runner.ctx.events:
            if event["kind"] != "replan":  # replans go out as the supervisor's ReplanEvent
                parse_frame({"type": "event", **event})
            kinds.add(event["kind"])
    assert {"obstacle_sensed", "deform", "dropout", "goal_reached"} <= kinds

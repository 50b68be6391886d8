"""One problem+json shape for every error of every route: generic title, specific detail, the
field at fault (with ``errors``) when a field is."""

from __future__ import annotations

from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from app.main import create_app
from app.settings import Settings
from tests.service.test_api import GOAL, wait_end

PROBLEM = "application/problem+json"


def problem(r: object, status: int, title: str) -> dict:
    assert r.status_code == status, r.text  # type: ignore[attr-defined]
    assert r.headers["content-type"].startswith(PROBLEM)  # type: ignore[attr-defined]
    body: dict = r.json()  # type: ignore[attr-defined]
    assert body["type"] == "about:blank" and body["status"] == status
    assert body["title"] == title and body["detail"] and body["detail"] != title
    if "field" in body:
        assert body["errors"][0]["field"] == body["field"]
    return body


@pytest.mark.parametrize("path", ["/missions", "/simulate", "/jobs/learn"])
@pytest.mark.parametrize(
    ("content", "ctype"),
    [
        (b'{"goals": [', "application/json"),
        (b"\xff\xfe", "application/json"),
        (b"--x\r\nbroken", "multipart/form-data; boundary=x"),
    ],
)
def test_an_unparseable_body_is_a_422_naming_the_body(
    client: TestClient, path: str, content: bytes, ctype: str
) -> None:
    r = client.post(path, content=content, headers={"Content-Type": ctype})
    body = problem(r, 422, "Unprocessable Entity")
    assert body["field"] == "body"


@pytest.mark.parametrize(
    ("path", "detail"),
    [
        ("/missions/nope", "mission nope not found"),
        ("/missions/nope/plan", "mission nope not found"),
        ("/missions/nope/trajectory", "mission nope not found"),
        ("/missions/nope/pddl", "mission nope not found"),
        ("/missions/nope/tree", "mission nope not found"),
        ("/missions/nope/events", "mission nope not found"),
        ("/plan?mission=nope", "mission nope not found"),
        ("/plan", "there are no missions yet"),
        ("/primitives/P99", "primitive 'P99' not found"),
        ("/jobs/nope", "job nope not found"),
        ("/examples/nope", "example 'nope' not found"),
    ],
)
def test_unknown_things_are_404_with_the_specific_message_in_detail(
    client: TestClient, path: str, detail: str
) -> None:
    body = problem(client.get(path), 404, "Not Found")
    assert body["detail"] == detail and "field" not in body


def test_conflicts_are_409_with_the_specific_message_in_detail(client: TestClient) -> None:
    mission = client.post("/missions", json=GOAL).json()
    wait_end(client, mission["id"])
    body = problem(client.post(f"/missions/{mission['id']}/cancel"), 409, "Conflict")
    assert body["detail"] == f"mission {mission['id']} already ended (succeeded)"
    first = client.post("/missions", json=GOAL, headers={"Idempotency-Key": "k1"})
    again = client.post("/missions", json=GOAL, headers={"Idempotency-Key": "k1"})
    assert first.status_code == 201 and again.status_code == 200  # a replay, declared
    other = client.post("/missions", json={**GOAL, "name": "x"}, headers={"Idempotency-Key": "k1"})
    body = problem(other, 409, "Conflict")
    assert body["field"] == "Idempotency-Key" and first.json()["id"] in body["detail"]


def test_an_unknown_chain_primitive_names_the_step(client: TestClient) -> None:
    r = client.post("/missions", json={"chain": [{"primitive": "P99", "until": {"duration": 5}}]})
    body = problem(r, 422, "Unprocessable Entity")
    assert body["field"] == "chain.0" and "P99" in body["detail"]
    assert body["errors"] == [
        {
            "field": "chain.0",
            "message": "primitive 'P99' is not in the library",
            "type": "value_error",
        }
    ]


def test_an_unknown_shape_is_422_on_primitives_as_on_missions(client: TestClient) -> None:
    body = problem(client.get("/primitives?shape=banana"), 422, "Unprocessable Entity")
    assert body["field"] == "shape" and "banana" in body["detail"]
    mission = problem(
        client.post("/missions", json={**GOAL, "shape": "banana"}), 422, "Unprocessable Entity"
    )
    assert mission["field"] == "shape"
    assert client.get("/primitives?shape=arc").json()["count"] > 0


def test_validation_errors_list_every_field(client: TestClient) -> None:
    r = client.post("/simulate", json={"theta": [2, 0, 0, 0], "dt": 0})
    body = problem(r, 422, "Unprocessable Entity")
    assert body["field"] == "theta.0" and body["detail"].startswith("theta.0: ")
    assert {e["field"] for e in body["errors"]} == {"theta.0", "dt"}
    body = problem(client.get("/missions?limit=0"), 422, "Unprocessable Entity")
    assert body["field"] == "limit"


@pytest.mark.parametrize(
    ("path", "body", "field"),
    [
        ("/simulate", {"theta": [True, 0, 0, 0]}, "theta.0"),
        ("/simulate", {"theta": [0.5, 0, 0, 0], "duration": "10"}, "duration"),
        ("/simulate", {"theta": [0.5, 0, 0, 0], "max_points": False}, "max_points"),
        ("/jobs/learn", {"goal": [True, -2]}, "goal.0"),
        ("/jobs/learn", {"goal": [-2, -2], "seed": True}, "seed"),
    ],
)
def test_a_boolean_or_a_string_is_not_a_number(
    client: TestClient, path: str, body: dict, field: str
) -> None:
    # as in a mission: JSON true is not 1, "10" is not 10
    answer = problem(client.post(path, json=body), 422, "Unprocessable Entity")
    assert answer["field"] == field


def test_a_missing_api_key_is_a_401_problem(tmp_path: Path) -> None:
    app = create_app(Settings(database_url=f"sqlite:///{tmp_path / 'k.db'}", api_key="s3cret"))
    with TestClient(app) as c:
        for path in ("/missions", "/jobs/learn", "/missions/x/cancel", "/missions/x/pause"):
            r = c.post(path, json={})
            body = problem(r, 401, "Unauthorized")
            assert r.headers["www-authenticate"] == "Bearer" and "API key" in body["detail"]

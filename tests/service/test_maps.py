"""Maps through the API: map_server's two files or JSON posted to /maps, stored once, read
back as posted; missions on known and hidden maps, inline or by id; every bad map a 422 that
names its field."""

from __future__ import annotations

import base64
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient

from tests.maps_fixtures import (
    OFFICE_MISSION,
    OFFICE_YAML,
    b64,
    office,
    office_map,
    pgm,
    png,
)
from tests.service.test_api import wait_end
from tests.service.test_live_updates import executing, wait_for


def post_files(client: TestClient, yaml: str, image: bytes, name: str = "office.pgm") -> Any:
    files = {"yaml": ("office.yaml", yaml.encode()), "image": (name, image)}
    return client.post("/maps", files=files)


def test_a_map_posted_as_files_is_stored_once_and_reads_back_as_posted(
    client: TestClient,
) -> None:
    image = pgm(office())
    first = post_files(client, OFFICE_YAML, image)
    assert first.status_code == 201, first.text
    map_id = first.json()["id"]
    assert first.headers["location"] == f"/maps/{map_id}"
    summary = first.json()["map"]
    assert (summary["width"], summary["height"], summary["format"]) == (120, 80, "pgm")
    assert summary["extent"] == {"xmin": -3.0, "xmax": 3.0, "ymin": -2.0, "ymax": 2.0}
    assert summary["cells"]["unknown"] == 200  # the band of 205s with free_thresh 0.196
    assert summary["name"] == "office.pgm"
    # the same map again (files, or JSON): the same id, nothing new stored
    again = post_files(client, OFFICE_YAML, image)
    assert again.status_code == 200 and again.json()["id"] == map_id
    as_json = {k: v for k, v in office_map().items() if k != "known"}
    same = client.post("/maps", json=as_json)
    assert same.status_code == 200 and same.json()["id"] == map_id
    listed = client.get("/maps").json()
    assert listed["total"] == 1 and listed["items"][0]["id"] == map_id
    stored = client.get(f"/maps/{map_id}").json()
    assert base64.b64decode(stored["image"]) == image
    assert stored["resolution"] == 0.05 and stored["origin"] == [-3.0, -2.0, 0.0]
    assert stored["free_thresh"] == 0.196 and stored["mode"] == "trinary"
    raw = client.get(f"/maps/{map_id}/image")
    assert raw.content == image and raw.headers["content-type"] == "image/x-portable-graymap"
    assert client.get("/maps/" + "0" * 32).status_code == 404


def test_a_png_with_negate_posts_and_reads_as_the_pgm(client: TestClient) -> None:
    inverted = 255 - office(unknown_band=False)
    yaml = OFFICE_YAML.replace("office.pgm", "office.png").replace("negate: 0", "negate: 1")
    posted = post_files(client, yaml, png(inverted), "office.png")
    assert posted.status_code == 201, posted.text
    cells = posted.json()["map"]["cells"]
    plain = post_files(client, OFFICE_YAML, pgm(office(unknown_band=False))).json()["map"]
    assert cells == plain["cells"] and cells["unknown"] == 0


def test_a_mission_on_a_known_map_by_id_reaches_its_goal(client: TestClient) -> None:
    map_id = post_files(client, OFFICE_YAML, pgm(office())).json()["id"]
    body = {**OFFICE_MISSION, "maps": [{"id": map_id, "known": True}]}
    created = client.post("/missions", json=body)
    assert created.status_code == 201, created.text
    mission = created.json()
    # the arena is the map's extent; the request keeps the map's id, not its image
    assert mission["request"]["bounds"] == {"xmin": -3.0, "xmax": 3.0, "ymin": -2.0, "ymax": 2.0}
    assert mission["request"]["maps"] == [{"id": map_id, "known": True}]
    end = wait_end(client, mission["id"], timeout=120)
    assert end["status"] == "succeeded", end["reason"]
    assert end["collisions"] == 0


def test_a_hidden_inline_map_is_sensed_and_planned_round(client: TestClient) -> None:
    body = {**OFFICE_MISSION, "maps": [office_map(known=False, unknown_band=False)]}
    created = client.post("/missions", json=body)
    assert created.status_code == 201, created.text
    mission = created.json()
    # stored by content hash and named by id in the stored request
    (entry,) = mission["request"]["maps"]
    assert entry["known"] is False and len(entry["id"]) == 32
    assert client.get(f"/maps/{entry['id']}").status_code == 200
    end = wait_end(client, mission["id"], timeout=180)
    assert end["status"] == "succeeded", end["reason"]
    assert end["replans"] >= 1  # the wall was not known: it was sensed, and planned round
    world = client.get(f"/missions/{mission['id']}/world").json()
    sensed = np.array(world["sensed"])
    assert len(sensed) and np.any(np.abs(sensed[:, 0]) < 0.15)  # cells of the middle wall


def bad(client: TestClient, body: dict[str, Any], field: str, where: str = "/missions") -> str:
    answer = client.post(where, json=body)
    assert answer.status_code == 422, answer.text
    assert answer.headers["content-type"].startswith("application/problem+json")
    problem = answer.json()
    assert problem["field"] == field, problem
    return str(problem["detail"])


def with_map(**change: Any) -> dict[str, Any]:
    return {**OFFICE_MISSION, "maps": [{**office_map(), **change}]}


def test_bad_maps_are_422_naming_the_field(client: TestClient) -> None:
    assert "PGM (P5) or PNG" in bad(
        client, with_map(image=b64(b"GIF89a" + bytes(20))), "maps.0.image"
    )
    assert "base64" in bad(client, with_map(image="not base64!"), "maps.0.image")
    bad(client, with_map(resolution=0), "maps.0.resolution")
    bad(client, with_map(resolution=-0.05), "maps.0.resolution")
    bad(client, with_map(origin=[0, 0]), "maps.0.origin.2")  # x, y and yaw
    bad(client, with_map(occupied_thresh=1.5), "maps.0.occupied_thresh")
    assert "below occupied_thresh" in bad(
        client, with_map(free_thresh=0.7, occupied_thresh=0.6), "maps.0.free_thresh"
    )
    bad(client, with_map(mode="fancy"), "maps.0.mode")
    assert "binary" in bad(client, with_map(known=False), "maps.0.known")
    assert "inside an occupied cell of maps.0" in bad(
        client, {**with_map(), "goals": [{"x": 0.0, "y": 1.5}]}, "goals.0"
    )
    assert "maps.0" in bad(client, {**with_map(), "start": {"x": 0.0, "y": 1.5}}, "start")
    assert "no map" in bad(
        client, {**OFFICE_MISSION, "maps": [{"id": "f" * 32, "known": True}]}, "maps.0.id"
    )
    bad(client, {**OFFICE_MISSION, "maps": [{"id": "nope", "known": True}]}, "maps.0.id")


def test_bad_map_posts_are_422_naming_the_field(client: TestClient) -> None:
    json_map = {k: v for k, v in office_map().items() if k != "known"}
    bad(client, {**json_map, "resolution": 0}, "resolution", "/maps")
    bad(client, {**json_map, "image": b64(b"P6\n1 1\n255\n\x00\x00\x00")}, "image", "/maps")
    answer = post_files(client, OFFICE_YAML.replace("resolution: 0.05", "resolution: -1"), b"")
    assert answer.status_code == 422 and answer.json()["field"] == "image"  # no image at all
    answer = post_files(
        client, OFFICE_YAML.replace("resolution: 0.05", "resolution: -1"), pgm(office())
    )
    assert answer.status_code == 422 and answer.json()["field"] == "resolution"
    answer = post_files(
        client, OFFICE_YAML.replace("[-3.0, -2.0, 0.0]", "[.nan, 0, 0]"), pgm(office())
    )
    assert answer.status_code == 422 and answer.json()["field"] == "origin"
    answer = post_files(client, OFFICE_YAML + "colour: red\n", pgm(office()))
    assert answer.status_code == 422 and answer.json()["field"] == "colour"
    answer = client.post("/maps", files={"image": ("office.pgm", pgm(office()))})
    assert answer.status_code == 422 and answer.json()["field"] == "yaml"
    answer = client.post("/maps", content=b"hello", headers={"content-type": "text/plain"})
    assert answer.status_code == 422 and answer.json()["field"] == "body"


@pytest.mark.parametrize("limit", [4096])
def test_maps_have_their_own_body_limit(tmp_path: Any, limit: int) -> None:
    from app.main import create_app
    from app.settings import Settings

    settings = Settings(
        database_url=f"sqlite:///{tmp_path / 'limits.db'}",
        max_running=1,
        warm_up=False,
        max_map_body=limit,
    )
    with TestClient(create_app(settings)) as client:
        big = post_files(client, OFFICE_YAML, pgm(office()))  # 9.6 kB of pixels
        assert big.status_code == 413
        small = np.full((20, 20), 254, np.uint8)
        ok = post_files(client, OFFICE_YAML, pgm(small))
        assert ok.status_code == 201, ok.text


def test_a_goal_added_live_inside_a_map_wall_is_refused(client: TestClient) -> None:
    map_id = post_files(client, OFFICE_YAML, pgm(office())).json()["id"]
    body = {**OFFICE_MISSION, "maps": [{"id": map_id, "known": True}], "speed": 5.0}
    mission = client.post("/missions", json=body).json()
    wait_for(client, mission["id"], executing)
    refused = client.post(f"/missions/{mission['id']}/goals", json={"x": 0.0, "y": 1.5})
    assert refused.status_code == 422, refused.text
    assert "inside an occupied cell of maps.0" in refused.json()["detail"]
    taken = client.post(f"/missions/{mission['id']}/goals", json={"x": -2.0, "y": -1.0})
    assert taken.status_code == 202, taken.text
    client.post(f"/missions/{mission['id']}/cancel")
    wait_end(client, mission["id"])

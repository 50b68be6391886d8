"""A mission's world model exported as map_saver does (GET /missions/{id}/world.yaml, .pgm): the
known obstacle and the sensed post occupied, where the robot went free, the rest unknown; the
files read back as the same map through POST /maps."""

from __future__ import annotations

import yaml
from fastapi.testclient import TestClient

from sim.maps import MapParams, load_raster
from sim.raster import FREE, OCCUPIED, UNKNOWN
from tests.service.test_api import wait_end
from tests.service.test_maps import post_files

# A known box, and a hidden post beside the way to the goal (sensed, and planned round); the
# arena's far corners are never seen.
MISSION = {
    "goals": [{"x": 1.5, "y": 0.0}],
    "bounds": {"xmin": -2, "xmax": 4, "ymin": -3, "ymax": 3},
    "obstacles": [
        {"type": "rectangle", "x": 0.5, "y": -1.2, "width": 0.4, "height": 0.4, "known": True},
        {"type": "circle", "x": 0.9, "y": 0.25, "radius": 0.1, "known": False},
    ],
}


def test_the_world_model_exports_as_map_saver_files(client: TestClient) -> None:
    assert client.get("/missions/nope/world.yaml").status_code == 404
    mission = client.post("/missions", json=MISSION).json()
    assert wait_end(client, mission["id"])["status"] == "succeeded"
    base = f"/missions/{mission['id']}"
    world = client.get(f"{base}/world").json()
    assert world["sensed"]  # the hidden post was sensed

    text = client.get(f"{base}/world.yaml")
    assert text.status_code == 200 and text.headers["content-type"].startswith("application/x-")
    meta = yaml.safe_load(text.text)
    assert meta["image"] == "world.pgm" and meta["mode"] == "trinary" and meta["negate"] == 0
    assert meta["resolution"] == world["resolution"] and meta["origin"] == [-2, -3, 0]
    image = client.get(f"{base}/world.pgm")
    assert image.headers["content-type"] == "image/x-portable-graymap"
    assert image.content.startswith(b"P5\n")
    params = MapParams(
        meta["resolution"],
        tuple(meta["origin"]),
        occupied_thresh=meta["occupied_thresh"],
        free_thresh=meta["free_thresh"],
    )
    raster = load_raster(image.content, params, 10**7)
    assert raster.cells.shape == (round(6 / meta["resolution"]), round(6 / meta["resolution"]))

    def at(x: float, y: float) -> int:
        return int(
            raster.cells[int((x + 2) / meta["resolution"]), int((y + 3) / meta["resolution"])]
        )

    assert at(0.5, -1.2) == OCCUPIED  # the known box
    for x, y in world["sensed"]:  # every sensed cell
        assert at(x, y) == OCCUPIED
    assert at(0.0, 0.0) == FREE and at(1.5, 0.0) == FREE  # where the robot lay
    assert at(3.9, 2.9) == UNKNOWN and at(-1.9, -2.9) == UNKNOWN  # corners never seen

    # map_server's files read back as the same map (POST /maps takes them as they are)
    stored = post_files(client, text.text, image.content, "world.pgm")
    assert stored.status_code == 201, stored.text
    cells = client.get(f"/maps/{stored.json()['id']}").json()["cells"]
    assert cells == {
        "occupied": int((raster.cells == OCCUPIED).sum()),
        "free": int((raster.cells == FREE).sum()),
        "unknown": int((raster.cells == UNKNOWN).sum()),
    }

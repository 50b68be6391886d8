"""Operator limits and faults through the app (TestClient): 413, 503 when the queue is full,
speed against the wall-clock limit, database failures, reconciliation, NUL characters, the
tree kept in the store. Behaviour that needs a real server is in test_reliability.py."""

from __future__ import annotations

import time
from collections.abc import Iterator
from datetime import timedelta
from pathlib import Path

import pytest
from fastapi.exceptions import RequestValidationError
from fastapi.testclient import TestClient
from sqlalchemy import text

from app.api.limits import check_mission
from app.main import create_app
from app.missions.spec import MissionSpec
from app.service import reconcile
from app.settings import Settings
from primitives.library import Library, load_bundled
from tests.service.test_readiness import wait_ready

GOAL = {
    "name": "limits",
    "goals": [{"x": -2, "y": -1}],
    "bounds": {"xmin": -5, "xmax": 5, "ymin": -5, "ymax": 5},
}
SLOW = {**GOAL, "goals": [{"x": -4, "y": 4}], "speed": 1}
PROBLEM = "application/problem+json"


def app_client(tmp_path: Path, **settings: object) -> TestClient:
    """An app on a SQLite file in ``tmp_path``; its workers skip the warm-up unless asked
    (``warm_up=True``): what these tests check does not depend on it, and each warm-up costs a
    worker seconds of CPU (test_readiness.py checks the warm-up)."""
    url = settings.pop("database_url", f"sqlite:///{tmp_path / 'limits.db'}")
    config = {"database_url": url, "warm_up": False, **settings}
    return TestClient(create_app(Settings.model_validate(config)))


def wait_status(
    c: TestClient, mission_id: str, statuses: tuple[str, ...], timeout: float = 60
) -> dict:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        m = c.get(f"/missions/{mission_id}").json()
        if m["status"] in statuses:
            return m
        time.sleep(0.05)
    raise AssertionError(f"mission {mission_id} never reached {statuses}")


def test_body_over_the_limit_is_413_before_parsing(tmp_path: Path) -> None:
    with app_client(tmp_path, max_body=2048) as c:
        big = {**GOAL, "name": "x" * 100, "obstacles": [], "pad": "y" * 5000}
        r = c.post("/missions", json=big)
        assert r.status_code == 413
        assert r.headers["content-type"] == PROBLEM
        assert "2048" in r.json()["detail"]
        assert c.get("/missions").json()["total"] == 0
        assert c.post("/missions", json=GOAL).status_code == 201  # a normal body still passes


def test_full_queue_is_503_with_retry_after_and_stores_nothing(tmp_path: Path) -> None:
    with app_client(tmp_path, max_running=1, max_queued=2) as c:
        ids = [c.post("/missions", json=SLOW).json()["id"]]
        wait_status(c, ids[0], ("planning", "executing"))  # the one slot is taken
        ids += [c.post("/missions", json=SLOW).json()["id"] for _ in range(2)]  # two wait
        r = c.post("/missions", json=SLOW)
        assert r.status_code == 503
        assert r.headers["content-type"] == PROBLEM and int(r.headers["Retry-After"]) > 0
        assert c.get("/missions").json()["total"] == 3  # no row for the refused one
        c.post(f"/missions/{ids[1]}/cancel")  # a waiting one leaves: room again
        assert c.post("/missions", json=SLOW).status_code == 201
        for mission_id in ids:
            c.post(f"/missions/{mission_id}/cancel")


@pytest.mark.parametrize(
    ("body", "detail"),
    [
        ({"speed": 1e-300}, "at least 0.01"),
        ({"speed": 1e-6}, "at least 0.01"),
        ({"speed": 0.1, "time_limit": 1000}, "wall-clock limit of 600"),
    ],
)
def test_speed_is_bounded_by_the_wall_clock_limit(tmp_path: Path, body: dict, detail: str) -> None:
    with app_client(tmp_path, wall_limit=600) as c:
        r = c.post("/missions", json={**GOAL, **body})
        assert r.status_code == 422 and r.json()["field"] == "speed"
        assert detail in r.json()["detail"]
        # within the bound: accepted (a one-second chain, which plans nothing: ends at once)
        short = {
            "shape": "zigzag",
            "chain": [{"primitive": "lat-zigzag-rp45p0", "until": {"duration": 1}}],
        }
        accepted = c.post("/missions", json={**short, "speed": 2, "time_limit": 1000})
        assert accepted.status_code == 201, accepted.text
        wait_status(c, accepted.json()["id"], ("succeeded",))


def test_arena_too_fine_for_the_planner_is_422(tmp_path: Path) -> None:
    with app_client(tmp_path) as c:
        huge = {**GOAL, "bounds": {"xmin": -500, "xmax": 500, "ymin": -500, "ymax": 500}}
        r = c.post("/missions", json=huge)
        assert r.status_code == 422 and r.json()["field"] == "bounds"


def test_a_mission_over_the_wall_clock_limit_fails_with_that_reason(tmp_path: Path) -> None:
    with app_client(tmp_path, wall_limit=1.0) as c:
        spin = {  # unpaced turns in place for 30000 model s: far more than 1 s of wall time
            "shape": "zigzag",
            "chain": [{"primitive": "lat-zigzag-rp45p0", "until": {"duration": 30000}}],
            "time_limit": 36000,
        }
        m = c.post("/missions", json=spin).json()
        m = wait_status(c, m["id"], ("succeeded", "failed", "cancelled"), timeout=30)
        assert (m["status"], m["reason"]) == ("failed", "wall-clock limit: 1 s reached")


def test_a_worker_stuck_in_planning_past_the_wall_clock_limit_is_stopped(tmp_path: Path) -> None:
    heavy = {  # pyperplan A*/hFF over 50 unordered goals: many seconds before the first step ends
        "goals": [{"x": -18 + (i % 10) * 4, "y": -18 + (i // 10) * 8} for i in range(50)],
        "order": "any",
        "bounds": {"xmin": -20, "xmax": 20, "ymin": -20, "ymax": 20},
        "planner": {"search": "astar", "heuristic": "hff", "time_limit": 120},
    }
    # 5 s: long enough for the worker to set the mission up and start planning on a busy
    # machine, far too short for the search
    with app_client(tmp_path, wall_limit=5.0) as c:
        m = c.post("/missions", json=heavy).json()
        m = wait_status(c, m["id"], ("succeeded", "failed", "cancelled"), timeout=60)
        assert (m["status"], m["reason"]) == ("failed", "wall-clock limit: 5 s reached")
        assert [t["status"] for t in m["transitions"]][-2:] == ["planning", "failed"]


def test_database_failure_is_503_and_readyz_false_without_leaking(tmp_path: Path) -> None:
    with app_client(tmp_path) as c:
        assert wait_ready(c.get).status_code == 200  # once a mission worker is warm
        app = c.app
        engine = app.state.services.store.engine  # type: ignore[attr-defined]
        app.state.db_health.window = 0.5  # type: ignore[attr-defined]
        with engine.begin() as conn:  # the write path breaks: OperationalError on INSERT
            conn.execute(text("ALTER TABLE transitions RENAME TO transitions_away"))
        r = c.post("/missions", json=GOAL)
        assert r.status_code == 503 and r.headers["content-type"] == PROBLEM
        assert r.headers["Retry-After"]
        ready = c.get("/readyz")
        assert ready.status_code == 503 and ready.headers["content-type"] == PROBLEM
        assert "database unavailable" in ready.json()["detail"]
        for body in (r.text, ready.text):
            assert str(tmp_path) not in body and "sqlite" not in body.lower()
        with engine.begin() as conn:
            conn.execute(text("ALTER TABLE transitions_away RENAME TO transitions"))
        time.sleep(0.6)
        assert c.get("/readyz").status_code == 200  # recovered
        assert c.post("/missions", json=GOAL).status_code == 201


def test_reconciliation_ends_missions_without_a_worker_and_requeues_lost_ones(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(reconcile, "SETTLE", timedelta(0))
    with app_client(tmp_path, reconcile_seconds=0.2) as c:
        store = c.app.state.services.store  # type: ignore[attr-defined]
        # As after a failed write: the store says executing, no worker runs it.
        orphan, _ = store.create_mission("orphan", {**GOAL}, None)
        store.transition(orphan.id, "planning")
        store.transition(orphan.id, "executing")
        # Stored but never queued (e.g. the server lost it): it must still run.
        lost, _ = store.create_mission("lost", {**GOAL}, None)
        m = wait_status(c, orphan.id, ("failed",), timeout=10)
        assert m["reason"].startswith("worker lost")
        assert wait_status(c, lost.id, ("succeeded",), timeout=60)["status"] == "succeeded"


@pytest.fixture
def nul_client(database_url: str, tmp_path: Path) -> Iterator[TestClient]:
    with app_client(tmp_path, database_url=database_url) as c:
        yield c


def test_nul_characters_are_422_on_every_backend(nul_client: TestClient) -> None:
    c = nul_client
    r = c.post("/missions", json={**GOAL, "name": "a\x00b"})
    assert r.status_code == 422 and r.json()["field"] == "name"
    for path in ("/missions/a%00b", "/missions/a%00b/plan", "/jobs/a%00b", "/plan?mission=a%00"):
        r = c.get(path)
        assert r.status_code == 422, path
        assert r.json()["field"] == "path"
    assert c.post("/missions/a%00b/cancel").status_code == 422
    assert c.get("/missions").json()["total"] == 0


def test_tree_is_freed_from_memory_after_the_end_and_kept_in_the_store(tmp_path: Path) -> None:
    with app_client(tmp_path) as c:
        m = c.post("/missions", json=GOAL).json()
        assert wait_status(c, m["id"], ("succeeded",))["status"] == "succeeded"
        deadline = time.monotonic() + 5
        hub = c.app.state.services.hub  # type: ignore[attr-defined]
        while m["id"] in hub.last_tree and time.monotonic() < deadline:
            time.sleep(0.05)
        assert m["id"] not in hub.last_tree
        tree = c.get(f"/missions/{m['id']}/tree").json()
        assert tree and "name" in tree


@pytest.mark.parametrize(
    ("body", "field"),
    [
        (  # a chain waiting on a sensor the robot does not have would run to its time limit
            {"chain": [{"primitive": "P1s", "until": {"sensor": "sonar", "below": 0.3}}]},
            "chain.0.until.sensor",
        ),
        (
            {
                "sensors": {"ring": 4},
                "chain": [{"primitive": "P1s", "until": {"sensor": "ring4", "below": 0.3}}],
            },
            "chain.0.until.sensor",
        ),
        (  # the paper's moves blend library shapes' primitives: this shape is no blend
            {**GOAL, "planner": {"domain": "reactive"}, "shape": {"joints": [1.2, -1.2, 1.2]}},
            "shape.joints",
        ),
        ({**GOAL, "shape": {"joints": [1.55, 0.0, 0.0]}}, "shape.joints"),  # past the joint limits
    ],
)
def test_what_would_fail_later_is_422_at_post(tmp_path: Path, body: dict, field: str) -> None:
    with app_client(tmp_path) as c:
        r = c.post("/missions", json=body)
        assert r.status_code == 422, r.text
        assert r.json()["field"] == field
        assert c.get("/missions").json()["total"] == 0
        ok = {"chain": [{"primitive": "P1s", "until": {"sensor": "ring3", "below": 0.3}}]}
        assert c.post("/missions", json={**ok, "sensors": {"ring": 4}}).status_code == 201


def test_a_shape_the_library_has_no_lattice_primitives_for_is_422_naming_shape() -> None:
    library = load_bundled()
    no_gait = Library(e for e in library if e.shape != "periodic" or e.family == "paper")
    spec = MissionSpec.model_validate({**GOAL, "shape": "periodic"})
    check_mission(spec, Settings(), library)  # the bundled library plans the gait
    with pytest.raises(RequestValidationError) as raised:
        check_mission(spec, Settings(), no_gait)
    (error,) = raised.value.errors()
    assert error["loc"] == ("body", "shape") and "no lattice primitives" in error["msg"]

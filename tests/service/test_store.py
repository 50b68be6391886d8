"""The store on SQLite always, and on PostgreSQL when SCREWSNAKE_TEST_POSTGRES is set."""

from __future__ import annotations

from fastapi.testclient import TestClient

from app.main import create_app
from app.settings import Settings
from app.store.db import make_engine, migrate
from app.store.repo import Store

REQUEST = {"name": "s", "goals": [{"x": 1, "y": 1}]}


def store_on(url: str) -> Store:
    engine = make_engine(url)
    migrate(engine)
    migrate(engine)  # idempotent
    return Store(engine)


def test_missions_transitions_and_idempotency(database_url: str) -> None:
    store = store_on(database_url)
    row, created = store.create_mission("s", REQUEST, "key-1")
    again, created_again = store.create_mission("s", REQUEST, "key-1")
    assert created and not created_again and again.id == row.id
    assert store.transition(row.id, "planning") and store.transition(
        row.id, "executing", state={"model_time": 3.0}
    )
    assert store.transition(row.id, "succeeded", "all goals reached")
    assert not store.transition(row.id, "failed", "too late")  # terminal is final
    assert [t.status for t in store.transitions(row.id)] == [
        "queued",
        "planning",
        "executing",
        "succeeded",
    ]
    got = store.get_mission(row.id)
    assert got is not None and got.status == "succeeded" and got.state == {"model_time": 3.0}
    rows, total = store.list_missions("succeeded", 10, 0)
    assert total == 1 and rows[0].id == row.id
    store.engine.dispose()


def test_plans_replans_trajectories_jobs_library(database_url: str) -> None:
    store = store_on(database_url)
    row, _ = store.create_mission("s", REQUEST, None)
    store.add_plan(
        row.id,
        1,
        "navigation",
        "(define (domain d))",
        "(define (problem p))",
        ["(move a b h_0 straight)"],
        [{"name": "move"}],
    )
    store.add_replan(
        row.id,
        {
            "trigger": "obstacle_sensed",
            "at": 3.5,
            "latency_ms": 4.2,
            "detail": {},
            "old": ["a"],
            "new": ["b"],
            "status": "solved",
        },
    )
    store.save_trajectory(row.id, [[0, 0, 0, 0, 0, 0, 0], [1, 0.1, 0, 0, 0, 0, 0]])
    store.save_trajectory(row.id, [[0, 0, 0, 0, 0, 0, 0]])  # replaced, not duplicated
    assert store.plans(row.id)[0].plan == ["(move a b h_0 straight)"]
    assert store.replans(row.id)[0].latency_ms == 4.2
    assert store.trajectory(row.id) == [[0, 0, 0, 0, 0, 0, 0]]
    job = store.create_job("learn", {"goal": [1, 1]})
    store.update_job(job.id, status="running", progress={"update": 3})
    assert store.get_job(job.id).progress == {"update": 3}
    store.interrupt_jobs()
    assert store.get_job(job.id).status == "failed"
    digest = store.record_library("{}", "0.1.0", 49, "bundled")
    assert store.record_library("{}", "0.1.0", 49, "bundled") == digest
    store.engine.dispose()


def test_restart_fails_interrupted_missions_and_keeps_finished_ones(database_url: str) -> None:
    store = store_on(database_url)
    done, _ = store.create_mission("done", REQUEST, None)
    store.transition(done.id, "planning")
    store.transition(done.id, "succeeded", "all goals reached")
    running, _ = store.create_mission("running", REQUEST, None)
    store.transition(running.id, "executing")
    store.engine.dispose()
    app = create_app(Settings(database_url=database_url))
    with TestClient(app) as client:
        m = client.get(f"/missions/{running.id}").json()
        assert m["status"] == "failed" and m["reason"] == "interrupted"
        d = client.get(f"/missions/{done.id}").json()
        assert d["status"] == "succeeded" and d["reason"] == "all goals reached"
        assert [t["status"] for t in d["transitions"]] == ["queued", "planning", "succeeded"]

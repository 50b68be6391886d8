"""The store on SQLite always, and on PostgreSQL when SCREWSNAKE_TEST_POSTGRES is set."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta
from pathlib import Path

from fastapi.testclient import TestClient
from sqlalchemy import func, select

from app.main import create_app
from app.settings import Settings
from app.store.db import make_engine, migrate
from app.store.models import BlobRow, PlanRow, TrajectoryRow
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
    store.transition(running.id, "planning")
    store.transition(running.id, "executing")
    store.engine.dispose()
    app = create_app(Settings(database_url=database_url))
    with TestClient(app) as client:
        m = client.get(f"/missions/{running.id}").json()
        assert m["status"] == "failed" and m["reason"] == "interrupted"
        d = client.get(f"/missions/{done.id}").json()
        assert d["status"] == "succeeded" and d["reason"] == "all goals reached"
        assert [t["status"] for t in d["transitions"]] == ["queued", "planning", "succeeded"]


def test_plan_texts_are_stored_once_compressed_and_read_back_byte_identical(
    database_url: str,
) -> None:
    store = store_on(database_url)
    row, _ = store.create_mission("s", REQUEST, None)
    domain = "(define (domain lattice)\n  (:predicates (at ?s)))\n"
    problems = [
        "; ünïcode comment\n(define (problem p) (:objects "
        + " ".join(f"s{i}" for i in range(n))
        + "))"
        for n in (2000, 1500)
    ]
    for version, problem in enumerate(problems, start=1):
        store.add_plan(row.id, version, "navigation", domain, problem, ["(move a b)"], [{"n": 1}])
    store.add_replan(
        row.id,
        {
            "trigger": "path_blocked",
            "at": 1.0,
            "latency_ms": 2.0,
            "detail": {"at": [0.5, 0.5]},
            "old": ["(move a b)", "(move b c)"],
            "new": ["(move a d)"],
            "status": "solved",
        },
    )
    plans = store.plans(row.id)
    assert [(p.domain_pddl, p.problem_pddl) for p in plans] == [(domain, q) for q in problems]
    assert plans[1].plan == ["(move a b)"] and plans[1].actions == [{"n": 1}]
    replan = store.replans(row.id)[0]
    assert replan.old == ["(move a b)", "(move b c)"] and replan.new == ["(move a d)"]
    assert store.replans(row.id)[0].old == replan.old  # filled in, never written back
    light = store.plans(row.id, texts=False, last=True)
    assert [p.version for p in light] == [2] and light[0].problem_pddl == ""
    with store.engine.connect() as conn:
        sizes = conn.execute(select(BlobRow.size, func.length(BlobRow.data))).all()
    # the domain once (not per version); each problem a fraction of its text
    assert sum(1 for size, _ in sizes if size == len(domain.encode())) == 1
    assert all(stored < size / 3 for size, stored in sizes if size > 5000)
    store.engine.dispose()


def test_rows_written_inline_by_the_first_layout_still_read(database_url: str) -> None:
    store = store_on(database_url)
    row, _ = store.create_mission("s", REQUEST, None)
    with store.sessions() as s:
        s.add(
            PlanRow(
                mission_id=row.id,
                version=1,
                domain="reactive",
                domain_pddl="(d)",
                problem_pddl="(p)",
                plan=["(po1)"],
                actions=[{"name": "po1"}],
            )
        )
        s.add(TrajectoryRow(mission_id=row.id, points=[[0, 1, 2, 3, 0, 0, 0]]))
        s.commit()
    plan = store.plans(row.id)[0]
    assert (plan.domain_pddl, plan.problem_pddl, plan.plan) == ("(d)", "(p)", ["(po1)"])
    assert store.trajectory(row.id) == [[0, 1, 2, 3, 0, 0, 0]]
    store.engine.dispose()


def test_retention_deletes_old_finished_missions_and_their_blobs(database_url: str) -> None:
    store = store_on(database_url)
    old, _ = store.create_mission("old", REQUEST, None)
    store.add_plan(old.id, 1, "navigation", "(dom)", "(only old)", ["x"], [])
    store.save_trajectory(old.id, [[0, 0, 0, 0, 0, 0, 0]])
    store.transition(old.id, "planning")
    store.transition(old.id, "succeeded", "all goals reached")
    running, _ = store.create_mission("running", REQUEST, None)
    store.add_plan(running.id, 1, "navigation", "(dom)", "(running)", ["y"], [])
    store.transition(running.id, "planning")
    store.transition(running.id, "executing")
    later = datetime.now(UTC) + timedelta(days=1)
    assert store.prune(later) == 1  # finished before `later`; the running one stays
    assert store.get_mission(old.id) is None and store.plans(old.id) == []
    assert store.trajectory(old.id) is None and store.transitions(old.id) == []
    assert store.plans(running.id)[0].domain_pddl == "(dom)"  # the shared text is kept
    with store.engine.connect() as conn:
        left = conn.execute(select(func.count()).select_from(BlobRow)).scalar()
    assert left == 3  # (dom), (running), running's steps
    assert store.prune(later) == 0
    store.engine.dispose()


def test_the_default_database_lives_in_the_data_directory(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "xdg"))
    monkeypatch.delenv("SCREWSNAKE_DATABASE_URL", raising=False)
    assert (
        Settings.from_env().database()
        == f"sqlite:///{tmp_path / 'xdg' / 'screwsnake' / 'screwsnake.db'}"
    )
    monkeypatch.setenv("SCREWSNAKE_DATA_DIR", str(tmp_path / "data"))
    assert Settings.from_env().database().endswith(f"{tmp_path}/data/screwsnake.db")
    monkeypatch.setenv("SCREWSNAKE_DATABASE_URL", "sqlite:////elsewhere/x.db")
    assert Settings.from_env().database() == "sqlite:////elsewhere/x.db"

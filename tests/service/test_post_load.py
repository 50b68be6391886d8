"""POST /missions under load (issue 15): batched intake, Server-Timing, blobs off the lock."""

from __future__ import annotations

import asyncio
import json
import lzma
import threading
from pathlib import Path
from typing import Any

import httpx
from fastapi.testclient import TestClient
from sqlalchemy import select

from app.main import create_app
from app.settings import Settings
from app.store import blobs
from app.store.models import BlobRow
from tests.service.test_server import start_server
from tests.service.test_store import store_on

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
MISSION = json.loads((EXAMPLES / "fig9b-obstacles.json").read_text())
REQUEST = {"name": "s", "goals": [{"x": 1, "y": 1}]}


def spans(response: httpx.Response) -> dict[str, float]:
    out = {}
    for part in response.headers["server-timing"].split(","):
        name, _, dur = part.strip().partition(";dur=")
        out[name] = float(dur)
    return out


def test_post_answers_with_where_its_time_went(client: TestClient) -> None:
    r = client.post("/missions", json=MISSION)
    assert r.status_code == 201
    timing = spans(r)
    assert {"accept", "validate", "store", "batch", "resource", "total"} <= set(timing)
    assert {"batch.lock", "batch.write"} <= set(timing)  # the batch's wait for the lock, its write
    assert timing["batch.lock"] + timing["batch.write"] <= timing["batch"] + 0.05
    assert all(ms >= 0 for ms in timing.values())
    laps = timing["accept"] + timing["validate"] + timing["store"] + timing["resource"]
    assert laps <= timing["total"] + 0.05  # the laps are consecutive parts of the total
    assert "total" in spans(client.get("/livez"))  # every answer has one


def test_server_timing_can_be_turned_off(tmp_path: Path) -> None:
    settings = Settings(
        database_url=f"sqlite:///{tmp_path / 'off.db'}", warm_up=False, server_timing=False
    )
    with TestClient(create_app(settings)) as c:
        assert "server-timing" not in c.post("/missions", json=MISSION).headers


def test_a_burst_of_posts_stores_and_queues_every_mission_once(tmp_path: Path) -> None:
    """20 posts at once against a real server, two with one Idempotency-Key: every post is
    answered from the store (201, or 200 for the retry), and every new mission is stored once."""
    proc, base = start_server(tmp_path / "burst.db")

    async def burst() -> list[httpx.Response]:
        async with httpx.AsyncClient(base_url=base, timeout=60) as http:
            posts: list[Any] = [
                http.post("/missions", json={**MISSION, "seed": k, "speed": 0}) for k in range(18)
            ]
            retried = {**MISSION, "seed": 99, "speed": 0}
            headers = {"Idempotency-Key": "burst-key"}
            posts += [http.post("/missions", json=retried, headers=headers) for _ in range(2)]
            return list(await asyncio.gather(*posts))

    try:
        answers = asyncio.run(burst())
        assert sorted(r.status_code for r in answers) == [200] + [201] * 19
        ids = {r.json()["id"] for r in answers}
        assert len(ids) == 19  # the two posts with one key made one mission
        for r in answers:
            assert r.headers["location"] == f"/missions/{r.json()['id']}"
            assert r.json()["status"] == "queued"
        created = [r.json() for r in answers if r.status_code == 201]
        assert all([t["status"] for t in m["transitions"]] == ["queued"] for m in created)
        with httpx.Client(base_url=base, timeout=30) as http:
            for mission_id in ids:
                stored = http.get(f"/missions/{mission_id}").json()
                assert stored["id"] == mission_id  # stored, then answered
            listed = http.get("/missions", params={"limit": 100}).json()
            assert listed["total"] == 19
    finally:
        proc.terminate()
        proc.wait(timeout=30)


def test_batched_inserts_keep_idempotency(database_url: str) -> None:
    store = store_on(database_url)
    first, created = store.create_mission("a", REQUEST, "key-a")
    assert created
    results = store.create_missions(
        [
            ("b", REQUEST, None),
            ("a again", REQUEST, "key-a"),  # used before
            ("c", REQUEST, "key-c"),
            ("c again", REQUEST, "key-c"),  # used earlier in this batch
            ("d", REQUEST, None),
        ]
    )
    assert [created for _, created in results] == [True, False, True, False, True]
    assert results[1][0].id == first.id and results[3][0].id == results[2][0].id
    assert len({row.id for row, _ in results}) == 4
    for row, _ in results:
        assert [t.status for t in store.transitions(row.id)] == ["queued"]
    assert store.list_missions(None, 100, 0)[1] == 4
    store.engine.dispose()


def test_batched_insert_takes_a_key_raced_in_by_another_writer(database_url: str) -> None:
    """A key another process commits between the batch's look-up and its commit: the batch
    falls back to one at a time, and only that item is a replay."""
    store = store_on(database_url)
    other = store_on(database_url)
    real = store._insert_missions
    raced: dict[str, str] = {}

    def racing(items: Any) -> Any:
        if not raced:
            row, _ = other.create_mission("other", REQUEST, "key-r")
            raced["id"] = row.id
        return real(items)

    store._insert_missions = racing  # type: ignore[method-assign]
    results = store.create_missions([("x", REQUEST, None), ("y", REQUEST, "key-r")])
    assert [created for _, created in results] == [True, False]
    assert results[1][0].id == raced["id"]
    assert store.list_missions(None, 100, 0)[1] == 2
    store.engine.dispose()
    other.engine.dispose()


def test_blobs_are_compressed_before_the_lock_and_read_back(database_url: str) -> None:
    store = store_on(database_url)
    row, _ = store.create_mission("s", REQUEST, None)
    problem = "(define (problem p) (:objects " + " ".join(f"w{i}" for i in range(3000)) + "))"
    locked = threading.Event()

    original = blobs.pack

    def pack(raw: bytes) -> bytes:
        if store.lock._is_owned():  # type: ignore[attr-defined]
            locked.set()
        return original(raw)

    blobs.pack = pack
    try:
        store.add_plan(row.id, 1, "navigation", "(define (domain d))", problem, ["a"], [{"a": 1}])
        store.save_trajectory(row.id, [[0.0, 1.0, 2.0]] * 500)
    finally:
        blobs.pack = original
    assert not locked.is_set()  # never compressed under the store's write lock
    plan = store.plans(row.id)[-1]
    assert plan.problem_pddl == problem and plan.actions == [{"a": 1}]
    assert store.trajectory(row.id) == [[0.0, 1.0, 2.0]] * 500
    with store.sessions() as s:
        stored = s.scalar(select(BlobRow).where(BlobRow.size == len(problem)))
        assert stored is not None and len(stored.data) < len(problem) / 5
        # the stream is the preset's: the old 64 MiB decoder reads it
        old = [{"id": lzma.FILTER_LZMA2, "preset": 9}]
        assert lzma.decompress(stored.data, format=lzma.FORMAT_RAW, filters=old) == (
            problem.encode()
        )
    store.engine.dispose()


def test_a_blob_deleted_after_it_was_prepared_is_stored_again(database_url: str) -> None:
    store = store_on(database_url)
    with store.sessions() as s:
        blobs.put(s, blobs.prepare(s, "some text"))
        s.commit()
        known = blobs.prepare(s, "some text")
    assert known.data is None  # known: not compressed again
    with store.sessions() as s:  # e.g. a retention sweep in between
        s.delete(s.get(BlobRow, known.digest))
        s.commit()
    with store.sessions() as s:
        assert blobs.put(s, known) == known.digest
        s.commit()
        assert blobs.get_text(s, known.digest) == "some text"
    store.engine.dispose()


def test_fitted_dictionary_sizes() -> None:
    assert blobs.dictionary_size(b"") == 4096
    assert blobs.dictionary_size(b"x" * 5000) == 8192
    assert blobs.dictionary_size(b"x" * (1 << 20)) == 1 << 20

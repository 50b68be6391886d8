"""Readiness means "can run missions now": ``/readyz`` is 503 while the mission workers warm up
and 200 once enough are warm (``SCREWSNAKE_READY_WORKERS``); its body counts them; a worker that
dies and is replaced is cold again until its own warm-up ends.

The warm-ups here are gated, not timed: each worker's warm-up waits until the test opens its gate
(a file named by the worker's pid), so "still cold" is certain, never a race with a clock."""

from __future__ import annotations

import functools
import os
import signal
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import httpx
import pytest
from fastapi.testclient import TestClient

from app.main import create_app
from app.service import pool, supervisor
from app.settings import Settings
from primitives.library import Library, bundled_library_path

PROBLEM = "application/problem+json"
GATE_POLL = 0.02  # seconds between a gated warm-up's looks at its gate
GATE_LIMIT = 120.0  # a gate never opened still lets the worker go (a failed test ends cleanly)
READY_TIMEOUT = 60.0  # generous: how long a poll waits for a state that must come


class GatedWarmUp:
    """A worker's warm-up that waits until ``gates/<its pid>`` or ``gates/all`` exists.
    Picklable (a pool process gets it by reference), run in the worker process."""

    def __init__(self, gates: Path) -> None:
        self.gates = gates

    def __call__(self, library: Library) -> None:
        deadline = time.monotonic() + GATE_LIMIT
        mine, every = self.gates / str(os.getpid()), self.gates / "all"
        while not (mine.exists() or every.exists()) and time.monotonic() < deadline:
            time.sleep(GATE_POLL)


def poll(
    get: Callable[[], httpx.Response], done: Callable[[httpx.Response], bool]
) -> httpx.Response:
    """``get()`` until ``done`` says so (within READY_TIMEOUT): the last answer."""
    deadline = time.monotonic() + READY_TIMEOUT
    while True:
        r = get()
        if done(r) or time.monotonic() > deadline:
            return r
        time.sleep(0.05)


def wait_ready(get: Callable[[str], httpx.Response]) -> httpx.Response:
    """``/readyz`` once it is 200 (a TestClient's or an HTTP client's ``get``)."""
    return poll(lambda: get("/readyz"), lambda r: r.status_code == 200)


def warm_count(r: httpx.Response) -> int:
    return int(r.json()["workers"]["warm"])


@contextmanager
def gated_client(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, **settings: object
) -> Iterator[tuple[TestClient, Path]]:
    """An app whose workers' warm-ups wait for their gates; (client, gates directory)."""
    gates = tmp_path / "gates"
    gates.mkdir()
    warm = GatedWarmUp(gates)
    monkeypatch.setattr(supervisor, "make_workers", functools.partial(pool.make_workers, warm=warm))
    url = f"sqlite:///{tmp_path / 'ready.db'}"
    app = create_app(Settings.model_validate({"database_url": url, **settings}))
    try:
        with TestClient(app) as c:
            yield c, gates
    finally:
        (gates / "all").touch()  # let every worker go: the service stops without waiting


def pids(c: TestClient) -> list[int]:
    workers = c.app.state.services.supervisor.workers  # type: ignore[attr-defined]
    return [w.pid for w in workers]


def test_not_ready_until_a_worker_is_warm_then_ready_and_saying_so(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    with gated_client(tmp_path, monkeypatch, max_running=2) as (c, gates):
        assert c.get("/livez").status_code == 200  # alive is not ready
        r = c.get("/readyz")
        assert r.status_code == 503 and r.headers["content-type"] == PROBLEM
        assert r.json()["detail"] == "workers warming up (0/2 warm)"
        assert r.json()["workers"] == {"warm": 0, "size": 2, "needed": 1}
        assert r.headers["Retry-After"]
        first, second = pids(c)
        (gates / str(first)).touch()
        r = wait_ready(c.get)
        assert r.status_code == 200
        body = r.json()
        assert body["status"] == "ok" and body["primitives"] == 181
        assert body["workers"] == {"warm": 1, "size": 2, "needed": 1}  # the other is gated
        (gates / str(second)).touch()
        r = poll(lambda: c.get("/readyz"), lambda r: warm_count(r) == 2)
        assert r.status_code == 200 and r.json()["workers"]["warm"] == 2
        metrics = c.get("/metrics").text
        assert "screwsnake_workers_warm 2.0" in metrics and "screwsnake_workers 2.0" in metrics


def test_a_worker_that_dies_and_is_replaced_is_cold_until_its_warm_up_ends(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    with gated_client(tmp_path, monkeypatch, max_running=1) as (c, gates):
        (pid,) = pids(c)
        (gates / str(pid)).touch()
        assert warm_count(wait_ready(c.get)) == 1
        os.kill(pid, signal.SIGKILL)  # dies while idle: no mission comes to replace it
        r = poll(lambda: c.get("/readyz"), lambda r: r.status_code == 503)
        assert r.json()["detail"] == "workers warming up (0/1 warm)"
        replaced = poll(lambda: c.get("/readyz"), lambda r: pids(c)[0] not in (pid, None))
        assert replaced.status_code == 503 and pids(c)[0] not in (pid, None)  # fresh, cold
        assert c.get("/readyz").json()["workers"] == {"warm": 0, "size": 1, "needed": 1}
        (gates / str(pids(c)[0])).touch()
        assert warm_count(wait_ready(c.get)) == 1


def test_the_setting_says_how_many_warm_workers_readiness_needs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    with gated_client(tmp_path, monkeypatch, max_running=2, ready_workers=0) as (c, _):
        r = c.get("/readyz")  # every worker still gated: 0 does not wait for them
        assert r.status_code == 200
        assert r.json()["workers"] == {"warm": 0, "size": 2, "needed": 0}
    (tmp_path / "more").mkdir()
    with gated_client(tmp_path / "more", monkeypatch, max_running=2, ready_workers=5) as (c, gates):
        first, second = pids(c)
        (gates / str(first)).touch()
        r = poll(lambda: c.get("/readyz"), lambda r: r.json()["workers"]["warm"] == 1)
        assert r.status_code == 503  # more than the pool asks for all of it
        assert r.json()["detail"] == "workers warming up (1/2 warm); 2 needed"
        (gates / str(second)).touch()
        r = wait_ready(c.get)
        assert r.json()["workers"] == {"warm": 2, "size": 2, "needed": 2}


def test_without_a_warm_up_a_worker_is_warm_once_it_runs(tmp_path: Path) -> None:
    app = create_app(Settings(database_url=f"sqlite:///{tmp_path / 'cold.db'}", warm_up=False))
    with TestClient(app) as c:
        r = wait_ready(c.get)
        assert r.status_code == 200 and r.json()["workers"]["warm"] >= 1


def test_the_readiness_body_is_described_in_the_schema(client: TestClient) -> None:
    schema = client.get("/openapi.json").json()
    op = schema["paths"]["/readyz"]["get"]
    ok = op["responses"]["200"]["content"]["application/json"]["schema"]
    assert ok == {"$ref": "#/components/schemas/Readiness"}
    components = schema["components"]["schemas"]
    assert set(components["Readiness"]["properties"]) == {
        "status",
        "database",
        "library",
        "primitives",
        "workers",
    }
    warmth = components["WorkerWarmth"]["properties"]
    assert set(warmth) == {"warm", "size", "needed"}
    assert all(spec["description"] for spec in warmth.values())
    assert "SCREWSNAKE_READY_WORKERS" in warmth["needed"]["description"]
    not_ready = op["responses"]["503"]["content"][PROBLEM]["schema"]["allOf"]
    assert not_ready[0] == {"$ref": "#/components/schemas/Problem"}
    assert not_ready[1]["properties"]["workers"]["$ref"] == "#/components/schemas/WorkerWarmth"
    body = wait_ready(client.get).json()  # and a real answer has exactly the schema's fields
    assert set(body) == set(components["Readiness"]["properties"])
    assert set(body["workers"]) == set(warmth)


def test_a_replaced_process_worker_starts_cold(tmp_path: Path) -> None:
    """The pool's own account: a worker is warm once its warm-up ends; ``restart`` makes a
    fresh process that is cold until its own warm-up ends."""
    gates = tmp_path / "gates"
    gates.mkdir()
    settings = Settings(database_url="sqlite://", max_running=1)
    library = Library.load(bundled_library_path())
    worker = pool.ProcessWorker(0, library, settings, GatedWarmUp(gates))
    try:
        assert not worker.warm()
        (gates / str(worker.pid)).touch()
        assert poll_until(worker.warm)
        old = worker.pid
        worker.restart()
        assert worker.pid != old and not worker.warm()  # its gate is closed: certainly cold
        (gates / str(worker.pid)).touch()
        assert poll_until(worker.warm)
    finally:
        (gates / "all").touch()
        worker.stop()


def poll_until(check: Callable[[], bool]) -> bool:
    deadline = time.monotonic() + READY_TIMEOUT
    while not check():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.05)
    return True


def test_a_worker_still_warming_up_is_stopped_at_once(tmp_path: Path) -> None:
    """Stopping the service while a worker warms up (its gate never opens) does not wait for
    the warm-up: the worker runs no mission yet, so it is killed without the stop's grace."""
    gates = tmp_path / "gates"
    gates.mkdir()
    settings = Settings(database_url="sqlite://", max_running=1)
    worker = pool.ProcessWorker(
        0, Library.load(bundled_library_path()), settings, GatedWarmUp(gates)
    )
    started = time.monotonic()
    worker.stop()
    assert time.monotonic() - started < pool.STOP_SECONDS / 2
    assert not worker.alive()

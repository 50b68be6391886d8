"""Plan versions' PDDL is written when someone asks, never on the mission's path: the worker
hands over what regenerates each problem; GET /missions/{id}/pddl/{version} renders it off the
loop, streamed, gzip-compressed when accepted, with a size cap (413 beyond); GET /pddl holds
small problems inline and says where large ones are."""

from __future__ import annotations

import pickle
import queue
import threading
import zlib
from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from app.executor.plan_versions import (
    SOURCE_HEADER,
    ZLIB_SOURCE_HEADER,
    SourceUnreadable,
    render,
    source_of,
)
from app.main import create_app
from app.missions.status import MissionStatus
from app.service.messages import Ended, Job, PlanMade, WorkerMessage
from app.service.worker import run_mission
from app.settings import Settings
from domain.goal_order import LegGoal
from domain.navigation import (
    NavigationSettings,
    Plan,
    Planner,
    PlanRequest,
    lattice_domain_text,
    motion_table,
)
from domain.pyperplan_adapter import validate_plan_text
from domain.world import WorldModel
from primitives.library import load_bundled
from sim.world import Bounds
from tests.app.test_pddl_export import without_costs
from tests.service.test_api import wait_end

# Fourteen goals in an open field: one tour whose problem lists fourteen legs' searches (over
# 10 MB of PDDL) while the mission itself plans and runs in seconds.
TOUR = {
    "goals": [
        {"x": 1.0 + 0.8 * (i % 5), "y": (-1) ** (i // 5) * (0.6 + 0.5 * (i // 5)), "tolerance": 0.2}
        for i in range(14)
    ],
    "bounds": {"xmin": -2, "xmax": 7, "ymin": -5, "ymax": 5},
    "time_limit": 900,
}
# Two goals and a hidden post between them: a tour, then replans round the post once sensed.
SMALL = {
    "order": "any",
    "goals": [{"x": -1.0, "y": -1.0}, {"x": 1.0, "y": -1.0}],
    "bounds": {"xmin": -2, "xmax": 2, "ymin": -2, "ymax": 2},
    "obstacles": [
        {"type": "circle", "x": 0.0, "y": -0.3, "radius": 0.2, "known": True},
        {"type": "circle", "x": -0.5, "y": -1.1, "radius": 0.15, "known": False},
    ],
}
MB = 1_000_000


@pytest.fixture
def lean(tmp_path: Path) -> Iterator[TestClient]:
    """A service that holds at most 1 MB of problems inline in GET /pddl."""
    settings = Settings(
        database_url=f"sqlite:///{tmp_path / 'api.db'}",
        max_running=1,
        warm_up=False,
        pddl_inline=MB,
    )
    with TestClient(create_app(settings)) as c:
        yield c


class Outbox(list[WorkerMessage]):
    def put(self, item: WorkerMessage) -> None:
        self.append(item)


def test_the_worker_hands_over_sources_never_problem_texts() -> None:
    out = Outbox()
    job = Job("tour", TOUR, wall_limit=120)
    run_mission(job, load_bundled(), 10.0, out, threading.Event(), queue.Queue())
    assert isinstance(out[-1], Ended) and out[-1].status == MissionStatus.SUCCEEDED
    plans = [m for m in out if isinstance(m, PlanMade)]
    texts = [render(p.problem_source) for p in plans]
    assert max(len(t) for t in texts) > 10 * MB  # the tour's problem: more than 10 MB
    # ... of which nothing crossed to the supervisor: all the mission's messages together are
    # about a tenth of it (each source a compact record of the searches, not their text)
    sent = sum(len(pickle.dumps(m)) for m in out)
    assert sent < sum(len(t) for t in texts) / 8
    assert not any("(define (problem" in repr(m) for m in out)


def test_a_versions_source_grows_with_its_search_not_with_the_arena() -> None:
    """The stored source of a plan version renders the plan's own problem, and the same plan in
    an arena 16 times the area stores about as much: the lattice's grid is kept as its bounds,
    not as its cells."""
    library, settings = load_bundled(), NavigationSettings()
    table = motion_table(library, "straight", (0.0, 0.0, 0.0), settings)
    assert table is not None
    sizes = []
    for half in (2.5, 10.0):
        bounds = Bounds(-half, half, -half, half)
        request = PlanRequest(
            (-1.0, 0.0, 3.14159), table, (LegGoal(0, 1.0, 0.0, 0.1),), True, WorldModel(bounds)
        )
        plan = Planner(bounds, settings).plan(request)
        assert isinstance(plan, Plan)
        problem = plan.problem()
        assert problem is not None
        source = source_of(plan)
        assert render(source) == problem.text()
        # one stored by an earlier version of the service (its pickle zlib'd) still renders
        older = ZLIB_SOURCE_HEADER + zlib.compress(source[len(SOURCE_HEADER) :])
        assert render(older) == problem.text()
        for broken in (source[:-20], older[:-20], b"screwsnake-pddl-source/9\n" + source):
            with pytest.raises(SourceUnreadable):
                render(broken)
        sizes.append(len(source))
    assert sizes[1] < 2 * sizes[0]


def test_a_large_problem_is_streamed_compressed_and_capped(lean: TestClient) -> None:
    mission = lean.post("/missions", json=TOUR).json()
    assert wait_end(lean, mission["id"])["status"] == "succeeded"
    listed = lean.get(f"/missions/{mission['id']}/pddl").json()
    large = [v for v in listed if not v["problem_inline"]]
    assert large and all(v["problem"] == "" for v in large)
    first = large[0]
    assert first["problem_bytes"] > 10 * MB  # rendered to learn its size; not inline
    url = first["problem_url"]
    assert url == f"/missions/{mission['id']}/pddl/{first['version']}"

    r = lean.get(url, headers={"Accept-Encoding": "gzip"})
    assert r.status_code == 200 and r.headers["content-encoding"] == "gzip"
    assert r.headers["content-type"].startswith("text/plain")
    assert int(r.headers["content-length"]) < first["problem_bytes"] / 5  # compressed
    assert r.content[:2] != b"\x1f\x8b"  # httpx decompressed it (a gzip stream, then)
    text = r.text
    assert len(text.encode()) == first["problem_bytes"] and "(define (problem" in text[:2000]
    assert text.count("(visited g") == len(TOUR["goals"])  # the goal: every goal visited
    # whoever does not accept gzip gets the text as it is
    plain = lean.get(url, headers={"Accept-Encoding": "identity"})
    assert "content-encoding" not in plain.headers and plain.content == text.encode()

    # past the answer's cap: 413 problem+json saying how large and which setting
    lean.app.state.services.settings.max_pddl_answer = 10 * MB  # type: ignore[attr-defined]
    capped = lean.get(url, headers={"Accept-Encoding": "gzip"})
    assert capped.status_code == 413
    assert capped.headers["content-type"] == "application/problem+json"
    detail = capped.json()["detail"]
    assert str(first["problem_bytes"]) in detail and "SCREWSNAKE_MAX_PDDL_ANSWER" in detail
    missing = lean.get(f"/missions/{mission['id']}/pddl/{len(listed) + 1}")
    assert missing.status_code == 404


@pytest.fixture
def roomy(tmp_path: Path) -> Iterator[TestClient]:
    """A service that holds up to 32 MB of problems inline in GET /pddl (a leg's problem lists
    up to ``exported_states`` searched states with their successors: megabytes)."""
    settings = Settings(
        database_url=f"sqlite:///{tmp_path / 'api.db'}", warm_up=False, pddl_inline=32 * MB
    )
    with TestClient(create_app(settings)) as c:
        yield c


def test_problems_rendered_when_asked_parse_and_solve_with_pyperplan(roomy: TestClient) -> None:
    client = roomy
    mission = client.post("/missions", json=SMALL).json()
    assert wait_end(client, mission["id"])["status"] == "succeeded"
    listed = client.get(f"/missions/{mission['id']}/pddl").json()
    assert len(listed) >= 2 and listed[0]["problem_inline"]
    inline = [v for v in listed if v["problem_inline"]]  # the first, while they fit in all
    assert sum(v["problem_bytes"] for v in inline) <= 32 * MB
    assert all(len(v["problem"].encode()) == v["problem_bytes"] for v in inline)
    solved = [v for v in listed if v["plan"]]
    assert solved and client.get(solved[0]["problem_url"]).text.count("(visited g") == 2
    for version in solved:
        r = client.get(version["problem_url"], headers={"Accept-Encoding": "gzip"})
        assert r.status_code == 200
        assert r.text == version["problem"] or not version["problem_inline"]
        domain = client.get(f"{version['problem_url']}?part=domain").text
        assert domain == version["domain"] == lattice_domain_text()
        ok = validate_plan_text(without_costs(domain), without_costs(r.text), version["plan"])
        assert ok == (True, "valid")
    # and the check can fail: the plan cut short does not reach the goal
    version = solved[0]
    problem = client.get(version["problem_url"]).text
    cut = validate_plan_text(
        without_costs(version["domain"]), without_costs(problem), version["plan"][:-1]
    )
    assert cut == (False, "the plan ends without reaching the goal")

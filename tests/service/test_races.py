"""Issue 29: live updates raced and abused. The answers give the real index however fast updates
come, the caps hold, the last goal cannot be removed, updates are checked against the mission's
current world, chain missions refuse planner updates alike, pause and resume are exact, and a
learning job queue has a cap. Each test failed before the change it holds."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from app.executor.runner import MissionRunner
from app.missions.spec import MissionSpec
from app.service import jobs
from app.service.messages import AddObstacle, RemoveGoal
from app.service.worker import apply_update
from primitives.library import Library, bundled_library_path
from tests.service.test_abuse import costly, counted_here
from tests.service.test_limits import app_client, wait_status

BOUNDS = {"xmin": -5, "xmax": 5, "ymin": -5, "ymax": 5}
# Paced (1 model s per wall second) towards a far goal: it runs for minutes unless cancelled.
LONG = {"name": "long", "goals": [{"x": -4, "y": 4}], "bounds": BOUNDS, "speed": 1}
TERMINAL = ("succeeded", "failed", "cancelled")


@contextmanager
def running(
    tmp_path: Path, body: dict | None = None, **settings: object
) -> Iterator[tuple[TestClient, str]]:
    """A client and a mission of ``body`` (default LONG) executing; cancelled at the end."""
    with app_client(tmp_path, max_running=1, warm_up=False, **settings) as c:
        mission = c.post("/missions", json=body or LONG).json()["id"]
        wait_status(c, mission, ("executing",))
        try:
            yield c, mission
        finally:
            c.post(f"/missions/{mission}/cancel")


def goal_at(k: int) -> dict:
    """A distinct free spot for the k-th goal added (k < 64)."""
    return {"x": -3.5 + (k % 8) * 1.0, "y": -3.5 + (k // 8) * 1.0, "tolerance": 0.1}


def at_once(calls: list, workers: int = 16) -> list:
    with ThreadPoolExecutor(workers) as pool:
        return list(pool.map(lambda call: call(), calls))


# -- 2: the answer is the real index -----------------------------------------------------------
def test_goals_added_in_a_row_are_answered_with_their_real_index(tmp_path: Path) -> None:
    with running(tmp_path) as (c, mission):
        answers = [c.post(f"/missions/{mission}/goals", json=goal_at(k)) for k in range(5)]
        assert [r.status_code for r in answers] == [202] * 5
        assert [r.json()["goal"] for r in answers] == [1, 2, 3, 4, 5]  # was 1, 1, 1, 1, 1
        r = c.delete(f"/missions/{mission}/goals/5")  # right after: its own goal, not a 404
        assert r.status_code == 202, r.text
        goals = c.get(f"/missions/{mission}").json()["goals"]
        assert len(goals) == 6 and goals[5]["removed"] and not goals[4]["removed"]
        assert (goals[3]["x"], goals[3]["y"]) == (goal_at(2)["x"], goal_at(2)["y"])


def test_concurrent_goal_adds_each_get_the_index_their_goal_landed_at(tmp_path: Path) -> None:
    with running(tmp_path) as (c, mission):
        calls = [
            (lambda k=k: c.post(f"/missions/{mission}/goals", json=goal_at(k))) for k in range(30)
        ]
        answers = at_once(calls)
        assert all(r.status_code == 202 for r in answers), [r.text for r in answers]
        indices = [r.json()["goal"] for r in answers]
        assert sorted(indices) == list(range(1, 31))
        goals = c.get(f"/missions/{mission}").json()["goals"]
        for k, index in enumerate(indices):  # the goal at the answered index is this one
            assert (goals[index]["x"], goals[index]["y"]) == (goal_at(k)["x"], goal_at(k)["y"])


# -- 3: caps hold however fast updates come ------------------------------------------------------
def test_the_goal_cap_holds_under_a_burst(tmp_path: Path) -> None:
    with running(tmp_path, max_goals=20) as (c, mission):
        calls = [
            (lambda k=k: c.post(f"/missions/{mission}/goals", json=goal_at(k))) for k in range(40)
        ]
        codes = sorted(r.status_code for r in at_once(calls))
        assert codes == [202] * 19 + [422] * 21  # 1 posted + 19 added; was 40 x 202
        assert len(c.get(f"/missions/{mission}").json()["goals"]) == 20
        r = c.post(f"/missions/{mission}/goals", json=goal_at(50))
        assert r.status_code == 422 and r.json()["field"] == "goals"
        assert "SCREWSNAKE_MAX_GOALS" in r.json()["detail"]


def test_the_live_obstacle_cap_holds_under_a_burst(tmp_path: Path) -> None:
    with running(tmp_path, max_live_obstacles=5) as (c, mission):

        def post(k: int) -> int:
            post = {"type": "circle", "x": 3.0, "y": -4.0 + 0.5 * k, "radius": 0.1}
            return c.post(f"/missions/{mission}/obstacles", json={"obstacle": post}).status_code

        codes = sorted(at_once([(lambda k=k: post(k)) for k in range(12)]))
        assert codes == [202] * 5 + [422] * 7  # was 12 x 202: no cap at all
        r = c.post(
            f"/missions/{mission}/obstacles",
            json={"obstacle": {"type": "circle", "x": 4, "y": 4, "radius": 0.1}},
        )
        assert r.status_code == 422 and "SCREWSNAKE_MAX_LIVE_OBSTACLES" in r.json()["detail"]


def test_posted_and_live_obstacles_stay_within_the_mission_cap(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("SCREWSNAKE_MAX_OBSTACLES", "3")  # read wherever a mission is validated
    posts = [{"type": "circle", "x": 3.0, "y": -4.0 + k, "radius": 0.1} for k in range(2)]
    with running(tmp_path, {**LONG, "obstacles": posts}) as (c, mission):
        more = {"type": "circle", "x": 4.0, "y": -4.0, "radius": 0.1}
        assert c.post(f"/missions/{mission}/obstacles", json={"obstacle": more}).status_code == 202
        r = c.post(f"/missions/{mission}/obstacles", json={"obstacle": {**more, "y": -3.0}})
        assert r.status_code == 422 and "SCREWSNAKE_MAX_OBSTACLES" in r.json()["detail"]


class HeldLearner:
    """A learner that learns nothing until the test lets it go (a job that runs long)."""

    def __init__(self, release: threading.Event) -> None:
        self.release = release

    def learn(self, task: object, seed: int, stop: object, progress: object = None) -> object:
        self.release.wait(30)
        raise ValueError("held")


def test_learning_jobs_waiting_are_capped(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    release = threading.Event()
    monkeypatch.setattr(jobs, "make_learner", lambda name: HeldLearner(release))
    try:
        with app_client(tmp_path, max_running=1, warm_up=False, max_queued_jobs=3) as c:
            first = c.post("/jobs/learn", json={"goal": [-2, -2]}).json()["id"]
            deadline = time.monotonic() + 10
            while c.get(f"/jobs/{first}").json()["status"] != "running":
                assert time.monotonic() < deadline
                time.sleep(0.02)
            codes = [c.post("/jobs/learn", json={"goal": [-2, -2]}).status_code for _ in range(6)]
            assert codes == [202] * 3 + [503] * 3, codes  # 3 wait behind the one running; was 6
            refused = c.post("/jobs/learn", json={"goal": [-2, -2]})
            assert refused.headers["Retry-After"]
            assert refused.headers["content-type"] == "application/problem+json"
            assert "learning jobs are waiting" in refused.json()["detail"]
            release.set()
    finally:
        release.set()


# -- 5: never a success with nothing reached ------------------------------------------------------
def test_the_last_goal_not_reached_cannot_be_removed(tmp_path: Path) -> None:
    two = {**LONG, "goals": [{"x": -4, "y": 4}, {"x": 4, "y": 4}]}
    with running(tmp_path, two) as (c, mission):
        assert c.delete(f"/missions/{mission}/goals/1").status_code == 202
        r = c.delete(f"/missions/{mission}/goals/0")
        assert r.status_code == 409, r.text  # was 202, then "succeeded: all goals reached"
        assert "cancel the mission instead" in r.json()["detail"]
        m = c.get(f"/missions/{mission}").json()
        assert m["status"] not in TERMINAL and not m["goals"][0]["removed"]


@pytest.fixture(scope="module")
def library() -> Library:
    return Library.load(bundled_library_path())


def test_the_worker_refuses_removing_the_last_goal_itself(library: Library) -> None:
    runner = MissionRunner(MissionSpec.model_validate({**LONG, "speed": 0}), library)
    apply_update(runner, RemoveGoal(0))  # as if the server's check had raced with the mission
    assert not runner.ctx.goals[0].removed
    refused = [e for e in runner.ctx.events if e["kind"] == "update"]
    assert refused[-1]["update"] == "remove_goal refused"
    assert "cancel the mission instead" in refused[-1]["detail"]["reason"]


# -- 6: live updates validated against the mission's current world --------------------------------
def test_a_goal_inside_an_obstacle_added_live_is_422(tmp_path: Path) -> None:
    with running(tmp_path) as (c, mission):
        wall = {"type": "circle", "x": 2, "y": 2, "radius": 0.5}
        added = c.post(f"/missions/{mission}/obstacles", json={"obstacle": wall})
        assert added.status_code == 202
        r = c.post(f"/missions/{mission}/goals", json={"x": 2, "y": 2})
        assert r.status_code == 422, r.text  # was 202, then "unreachable: goal 1 enclosed"
        assert r.json()["detail"] == "goal: inside obstacles.0" and r.json()["field"] == "body"
        assert added.json()["obstacle"] == 0  # the index the messages use
        r = c.post(f"/missions/{mission}/goals", json={"x": 2, "y": 2.52})  # touching it
        assert r.status_code == 422 and "closer to obstacles.0" in r.json()["detail"]
        assert c.get(f"/missions/{mission}").json()["status"] not in TERMINAL


def test_an_obstacle_on_or_around_the_robot_or_over_a_goal_is_422(tmp_path: Path) -> None:
    with running(tmp_path) as (c, mission):
        c.post(f"/missions/{mission}/pause")
        wait_status(c, mission, ("paused",))
        pose = c.get(f"/missions/{mission}").json()["pose"]
        x, y = pose["x"], pose["y"]
        for obstacle in (
            {"type": "circle", "x": x, "y": y, "radius": 0.05},  # on the head
            {"type": "rectangle", "x": x, "y": y, "width": 4, "height": 4},  # around it all
            {"type": "circle", "x": -4, "y": 4, "radius": 0.3},  # over the goal
            {"type": "circle", "x": -4, "y": 4.32, "radius": 0.3},  # the goal out of reach
        ):
            r = c.post(f"/missions/{mission}/obstacles", json={"obstacle": obstacle})
            assert r.status_code == 422, (obstacle, r.text)  # was 202, then a false failure
            assert r.json()["field"] == "obstacle"
        r = c.post(
            f"/missions/{mission}/obstacles",
            json={"obstacle": {"type": "circle", "x": x, "y": y, "radius": 4}},
        )
        assert "robot's body" in r.json()["detail"]
        assert c.post(f"/missions/{mission}/resume").status_code == 202
        assert c.get(f"/missions/{mission}").json()["status"] not in TERMINAL


def test_the_worker_refuses_an_obstacle_on_the_body_itself(library: Library) -> None:
    runner = MissionRunner(MissionSpec.model_validate({**LONG, "speed": 0}), library)
    x, y, _ = runner.ctx.pose
    apply_update(runner, AddObstacle({"type": "circle", "x": x, "y": y, "radius": 0.2}))
    assert runner.ctx.trigger is None  # no replan against a world the robot is inside
    assert runner.ctx.events[-1]["update"] == "add_obstacle refused"


def test_live_updates_are_validated_off_the_event_loop(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    calls = counted_here(monkeypatch)
    with running(tmp_path, {**costly(5, 20, bad=False), "speed": 1}) as (c, mission):
        calls.clear()
        r = c.post(f"/missions/{mission}/goals", json={"x": -9.0, "y": 2.22})
        assert r.status_code == 422 and "closer to obstacles.0" in r.json()["detail"]
        assert calls == []  # was one per obstacle, in a thread holding the GIL


# -- 7: chain missions refuse every planner update alike --------------------------------------------
CHAIN = {"name": "chain", "chain": [{"primitive": "P1s", "until": {"duration": 3000}}], "speed": 1}


def test_a_chain_mission_answers_409_to_every_planner_update(tmp_path: Path) -> None:
    with running(tmp_path, CHAIN) as (c, mission):
        circle = {"type": "circle", "x": 3, "y": 3, "radius": 0.2}
        for method, path, body in (
            ("post", "obstacles", {"obstacle": circle}),  # was 202, then refused by the worker
            ("post", "goals", {"x": 1, "y": 1}),
            ("delete", "goals/0", None),
        ):
            r = c.request(method, f"/missions/{mission}/{path}", json=body)
            assert r.status_code == 409, (path, r.text)
            assert "no planner" in r.json()["detail"], path
        assert c.post(f"/missions/{mission}/pause").status_code == 202  # not a planner update


# -- pause and resume read the same account ---------------------------------------------------------
def test_pause_and_resume_twice_are_both_409(tmp_path: Path) -> None:
    with running(tmp_path) as (c, mission):
        assert c.post(f"/missions/{mission}/pause").status_code == 202
        assert c.post(f"/missions/{mission}/pause").status_code == 409
        assert c.post(f"/missions/{mission}/resume").status_code == 202
        second = c.post(f"/missions/{mission}/resume")  # was 202: the stored status lagged
        assert second.status_code == 409 and "not paused" in second.json()["detail"]
        assert c.post(f"/missions/{mission}/pause").status_code == 202

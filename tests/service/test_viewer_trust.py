"""The viewer shows nothing false at any moment: the status the mission is in, the goals and
obstacles it knows, the world model of the replayed time, plan labels clear of what they
would hide, a tree panel that says what it shows. Playwright driving Debian's Chromium; what
the canvas drew is read from ``window.viewer.drawn`` (boxes in canvas pixels)."""

from __future__ import annotations

import re
import subprocess
import time
from collections.abc import Iterator
from typing import Any

import httpx
import pytest

from tests.service.test_browser import (  # noqa: F401  (browser: a fixture)
    CHROMIUM,
    browser,
    post,
    shot,
    status_is,
    wait_ended,
)
from tests.service.test_server import start_server

pytestmark = [
    pytest.mark.skipif(
        not CHROMIUM.exists(), reason="Debian chromium is not installed (.ci/run installs it)"
    ),
    pytest.mark.xdist_group("viewer-trust"),  # the module's one server and finished mission
]
LIVE_SPEED = 3  # cluttered-field lasts about 65 wall seconds: time to look; each test cancels it


@pytest.fixture(scope="module")
def base(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """One server for the module: each test posts its own missions."""
    proc, url = start_server(tmp_path_factory.mktemp("viewer") / "trust.db")
    yield url
    proc.terminate()
    try:
        proc.wait(timeout=20)
    except subprocess.TimeoutExpired:  # a shutdown that hangs is not this module's subject
        proc.kill()
        proc.wait(timeout=10)


@pytest.fixture(scope="module")
def finished(base: str) -> str:
    """A finished cluttered-field mission (hidden obstacles sensed along the way)."""
    mission_id = post(base, "cluttered-field")
    assert wait_ended(base, mission_id)["status"] == "succeeded"
    return mission_id


def open_page(browser: Any, base: str, width: int = 1280, height: int = 800) -> Any:  # noqa: F811
    page = browser.new_page(viewport={"width": width, "height": height})
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.errors = errors
    page.goto(base + "/")
    return page


def cancel(base: str, mission_id: str) -> None:
    httpx.post(f"{base}/missions/{mission_id}/cancel", timeout=10)
    wait_ended(base, mission_id)


def replay_at(page: Any, t: float) -> float:
    """Set the replay slider to ``t`` (it snaps to its step); the time it shows."""
    shown: float = page.eval_on_selector(
        "#slider",
        "(s, t) => { s.value = t; s.dispatchEvent(new Event('input')); return Number(s.value); }",
        t,
    )
    page.wait_for_function(
        "t => window.viewer.replayT === t && window.viewer.drawn", arg=shown, timeout=5000
    )
    page.wait_for_timeout(100)  # a frame drawn with it
    return shown


def open_finished(page: Any, mission_id: str) -> None:
    page.wait_for_selector(f"#missions li[data-id='{mission_id}']")
    page.click(f"#missions li[data-id='{mission_id}']")
    page.wait_for_function(
        "id => window.viewer.mission && window.viewer.mission.id === id", arg=mission_id
    )
    page.wait_for_selector("#replay:not([hidden])")


def overlapping(a: list[float], b: list[float]) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def test_pause_then_resume_by_button_shows_the_missions_status(base: str, browser: Any) -> None:  # noqa: F811
    """The answer to Pause (202, the status when taken: executing) comes after the websocket's
    `paused`: it must not put "executing" back. Here the answer is held back 1 s so that it
    always comes last (it did 1 time in 10 by itself)."""
    mission_id = post(base, "cluttered-field", speed=LIVE_SPEED)
    page = open_page(browser, base)

    def late(route: Any) -> None:
        answer = route.fetch()
        time.sleep(1.0)
        route.fulfill(response=answer)

    page.route("**/missions/*/pause", late)
    page.route("**/missions/*/resume", late)
    status_is(page, "executing")
    assert "worker pid" not in page.inner_text("#status")  # internal, kept in the transitions
    page.click("#pause")
    assert "pause requested" in page.inner_text("#status")  # until the websocket says
    status_is(page, "paused", timeout=10_000)
    page.wait_for_timeout(1500)  # the held-back 202 has come meanwhile
    assert page.inner_text("#mission-status") == "paused"
    assert page.is_visible("#resume") and not page.is_visible("#pause")
    assert httpx.get(f"{base}/missions/{mission_id}").json()["status"] == "paused"
    frozen = page.evaluate("window.viewer.pose.t")
    page.wait_for_timeout(600)
    assert page.evaluate("window.viewer.pose.t") == frozen  # model time stands still
    page.select_option("#filter", "paused")  # the list filters by every status, paused too
    page.wait_for_function("document.querySelectorAll('#missions li').length === 1")
    assert page.get_attribute("#missions li", "data-status") == "paused"
    shot(page, "viewer-paused.png")

    page.click("#resume")
    status_is(page, "executing", timeout=60_000)  # after the replan that resuming asks for
    page.wait_for_timeout(1500)
    assert page.inner_text("#mission-status") in ("executing", "replanning")
    assert page.is_visible("#pause") and not page.is_visible("#resume")
    page.wait_for_function(f"window.viewer.pose.t > {frozen}")
    cancel(base, mission_id)
    assert page.errors == []


def test_goals_and_obstacles_added_live_appear_within_a_second(base: str, browser: Any) -> None:  # noqa: F811
    mission_id = post(base, "fig9a-single-goal", speed=LIVE_SPEED)  # an open arena: quick replans
    page = open_page(browser, base)
    status_is(page, "executing")
    page.wait_for_function("window.viewer.pose && window.viewer.pose.t > 1")
    goal = httpx.post(f"{base}/missions/{mission_id}/goals", json={"x": -3.5, "y": 3.0})
    assert goal.status_code == 202 and goal.json()["goal"] == 1
    wall = {"type": "rectangle", "x": 3.0, "y": -2.0, "width": 1.2, "height": 0.3, "angle": 0.3}
    assert httpx.post(f"{base}/missions/{mission_id}/obstacles", json=wall).status_code == 202
    # The worker takes an update at its next tick and sends its event once that tick (which
    # may replan) is done; from the event on, the map shows both within a second.
    page.wait_for_function(
        "() => window.viewer.events.filter(e => e.kind === 'update').length >= 2", timeout=90_000
    )
    page.wait_for_function(
        "() => { const d = window.viewer.drawn; return d.goals.some(g => g.index === 1) &&"
        " d.obstacles.includes('live-0'); }",
        timeout=1000,
    )
    drawn = page.evaluate("window.viewer.drawn")
    assert [g["index"] for g in drawn["goals"]] == [0, 1]  # labelled by the API's index
    assert "goals 0/2" in page.inner_text("#goals")  # the status bar agrees with the map
    page.wait_for_function(  # and the list, at its next poll
        "id => document.querySelector(`#missions li[data-id='${id}'] .meta`).textContent"
        ".includes('goals 0/2')",
        arg=mission_id,
        timeout=5000,
    )
    page.wait_for_function(
        "() => Array.from(document.querySelectorAll('#events li')).some("
        "li => li.textContent.includes('goal 1 added at (-3.50, 3.00) m'))"
    )
    shot(page, "viewer-live-updates.png")

    # Reloaded: the obstacle and goal come from the mission resource, the trail from the start.
    # (the mission's state is saved about once a second, between the worker's ticks)
    page.reload()
    page.wait_for_function(
        "() => window.viewer.drawn && window.viewer.drawn.obstacles.includes('live-0')"
        " && window.viewer.drawn.goals.length === 2",
        timeout=60_000,
    )
    page.wait_for_function("window.viewer.trail.length > 5")
    first = page.evaluate("window.viewer.trail[0][0]")
    assert first < 1.0, first  # the path before the reload is drawn too
    cancel(base, mission_id)
    assert page.errors == []


def test_a_replay_shows_the_world_model_of_its_time(base: str, finished: str, browser: Any) -> None:  # noqa: F811
    changes = httpx.get(f"{base}/missions/{finished}/replay").json()["world"]
    first_seen = min(c["t"] for c in changes if c.get("sensed"))
    page = open_page(browser, base)
    open_finished(page, finished)
    page.check("#truth")
    end = httpx.get(f"{base}/missions/{finished}/world").json()
    assert page.evaluate("window.viewer.drawn.sensed") == len(end["sensed"])

    replay_at(page, first_seen - 1)
    assert page.evaluate("window.viewer.drawn.sensed") == 0  # nothing was sensed yet
    shot(page, "viewer-replay-early.png")
    middle = replay_at(page, (first_seen + end["model_time"]) / 2)
    then = httpx.get(f"{base}/missions/{finished}/world", params={"at": middle}).json()
    assert (
        0 < page.evaluate("window.viewer.drawn.sensed") == len(then["sensed"]) < len(end["sensed"])
    )
    assert re.search(r"goal 0 reached, \d+\.\d cm off", page.inner_text("#events"))  # units
    assert page.errors == []


def test_plan_labels_never_cover_obstacles_goals_or_each_other(
    base: str,
    finished: str,
    browser: Any,  # noqa: F811
) -> None:
    page = open_page(browser, base, 1024, 640)
    open_finished(page, finished)
    page.check("#truth")  # hidden obstacles count as obstacles too
    box = page.locator("#arena").bounding_box()
    for t in (20, 60, 120):
        replay_at(page, t)
        dots = page.evaluate("window.viewer.drawn.dots")
        assert len(dots) > 5
        for dot in dots[::3]:  # the current step's label, and the hovered one's
            page.mouse.move(box["x"] + dot["x"], box["y"] + dot["y"])
            page.wait_for_timeout(40)
            drawn = page.evaluate("window.viewer.drawn")
            labels = drawn["labelBoxes"]
            assert len(labels) <= 2
            for label in labels:
                assert re.fullmatch(r"\d+ \S+", label["text"]), label
                for obstacle in drawn["obstacleBoxes"]:
                    assert not overlapping(label["box"], obstacle["box"]), (t, label, obstacle)
                for goal in drawn["goals"]:
                    assert not overlapping(label["box"], goal["box"]), (t, label, goal)
            if len(labels) == 2:
                assert not overlapping(labels[0]["box"], labels[1]["box"])
        if t == 60:
            page.mouse.move(box["x"] + dots[4]["x"], box["y"] + dots[4]["y"])
            page.wait_for_timeout(60)
            shot(page, "viewer-labels-1024.png")
    assert page.evaluate("window.viewer.drawn.goals[0].index") == 0  # the goal, above the plan
    end = page.evaluate("Number(document.querySelector('#slider').max)")
    replay_at(page, end)
    drawn = page.evaluate("window.viewer.drawn")
    assert drawn["planFaded"] and drawn["dots"] == [] and drawn["labelBoxes"] == []  # done
    # A smaller window refits the arena (until the user pans or zooms).
    before = drawn["view"]["scale"]
    page.set_viewport_size({"width": 800, "height": 500})
    page.wait_for_function(f"window.viewer.drawn.view.scale < {before} * 0.9")
    assert page.evaluate("window.viewer.drawn.view.fitted")
    assert page.errors == []


def test_the_tree_panel_shows_current_feedback_in_its_status_colour(
    base: str,
    finished: str,
    browser: Any,  # noqa: F811
) -> None:
    mission_id = post(base, "cluttered-field", speed=LIVE_SPEED)
    page = open_page(browser, base)
    page.wait_for_selector("#tree .node.RUNNING.current", timeout=60_000)
    page.wait_for_function("window.viewer.pose && window.viewer.pose.t > 1")
    # the panel and the snapshot it shows, read at once (a state frame replaces both)
    shown, snapshot = page.evaluate(
        """() => {
            const nodes = Array.from(document.querySelectorAll('#tree .node')).map(n => ({
                status: n.dataset.status,
                feedback: n.querySelector('.fb') ? n.querySelector('.fb').textContent : null,
                border: getComputedStyle(n).borderLeftColor,
                colour: n.querySelector('.fb') ? getComputedStyle(n.querySelector('.fb')).color : null,
            }));
            const flat = [];
            const walk = n => { flat.push({status: n.status, feedback: n.feedback}); (n.children || []).forEach(walk); };
            walk(window.viewer.tree);
            return [nodes, flat];
        }"""
    )
    assert [s["status"] for s in shown] == [n["status"] for n in snapshot]
    borders: dict[str, set[str]] = {}
    for node, reported in zip(shown, snapshot, strict=True):
        borders.setdefault(node["status"], set()).add(node["border"])
        if node["status"] == "INVALID":  # not ticked now: what it said last is old
            assert node["feedback"] is None, node
        else:
            assert node["feedback"] == (reported["feedback"] or None)
        if node["feedback"]:
            assert node["colour"] != "rgb(102, 102, 102)"  # in its status' colour, not grey
    assert all(len(colours) == 1 for colours in borders.values()), borders  # one per status
    assert len({next(iter(c)) for c in borders.values()}) == len(borders)  # and distinct
    assert any(n["status"] == "INVALID" for n in shown)
    shot(page, "viewer-tree.png")
    cancel(base, mission_id)

    # A replay before the end: the only snapshot is the end's, and the panel says so.
    open_finished(page, finished)
    assert page.inner_text("#tree-time") == "last snapshot"
    assert "stale" not in (page.get_attribute("#tree", "class") or "")
    replay_at(page, 30)
    assert page.inner_text("#tree-time").startswith("as it ended at")
    assert "stale" in page.get_attribute("#tree", "class")
    assert page.errors == []


def test_the_legend_names_what_the_map_draws_once_each(base: str, browser: Any) -> None:  # noqa: F811
    page = open_page(browser, base)
    entries = page.eval_on_selector_all("#legend div", "ds => ds.map(d => d.textContent)")
    assert len(entries) == len(set(entries))
    assert len([e for e in entries if "contact" in e]) == 1  # the cells; the event is "collision"
    for needed in ("robot body", "head", "current step", "obstacle added live", "goal N"):
        assert any(needed in e for e in entries), needed
    assert page.errors == []

"""The viewer in a real browser: Playwright driving Debian's Chromium (/usr/bin/chromium).

Each test asserts what a user sees (texts, visible elements) or what the map drew (the viewer
exposes its scene as ``window.viewer``); screenshots go to test-artifacts/.
"""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest

from tests.service.test_server import server, start_server  # noqa: F401  (fixture)

CHROMIUM = Path("/usr/bin/chromium")
ARTIFACTS = Path(__file__).parents[2] / "test-artifacts"
EXAMPLES = Path(__file__).parents[2] / "examples"
ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-quic",
    "--no-first-run",
    "--disable-component-update",
    "--disable-sync",
]
pytestmark = pytest.mark.skipif(
    not CHROMIUM.exists(), reason="Debian chromium is not installed (.ci/run installs it)"
)


@pytest.fixture
def browser() -> Iterator[Any]:
    sync_api = pytest.importorskip("playwright.sync_api")
    with sync_api.sync_playwright() as p:
        chromium = p.chromium.launch(executable_path=str(CHROMIUM), args=ARGS)
        yield chromium
        chromium.close()


def new_page(browser: Any, base: str) -> Any:
    page = browser.new_page(viewport={"width": 1280, "height": 800})
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.errors = errors
    page.goto(base + "/")
    return page


def shot(page: Any, name: str) -> None:
    ARTIFACTS.mkdir(exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / name))
    assert (ARTIFACTS / name).stat().st_size > 10_000


def post(base: str, example: str, speed: float = 0, headers: dict[str, str] | None = None) -> str:
    body = json.loads((EXAMPLES / f"{example}.json").read_text())
    body["speed"] = speed
    r = httpx.post(f"{base}/missions", json=body, headers=headers or {}, timeout=10)
    assert r.status_code == 201, r.text
    return str(r.json()["id"])


def wait_ended(base: str, mission_id: str, timeout: float = 120) -> dict[str, Any]:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        m: dict[str, Any] = httpx.get(f"{base}/missions/{mission_id}", timeout=10).json()
        if m["status"] in ("succeeded", "failed", "cancelled"):
            return m
        time.sleep(0.3)
    raise AssertionError(f"mission {mission_id} did not end")


def status_is(page: Any, status: str, timeout: float = 60_000) -> None:
    page.wait_for_function(
        "s => document.querySelector('#mission-status')?.textContent === s",
        arg=status,
        timeout=timeout,
    )


def test_viewer_posts_a_mission_and_shows_its_end(server: str, browser: Any) -> None:  # noqa: F811
    page = new_page(browser, server)
    page.wait_for_function("document.querySelectorAll('#example option').length > 0")
    page.select_option("#example", "fig9b-obstacles")
    page.fill("#speed", "50")
    page.click("#post button[type=submit]")
    status_is(page, "succeeded")
    status = page.inner_text("#status")
    assert "fig9b-obstacles" in status and "succeeded" in status and "✓" in status
    assert "straight-g" in page.inner_text("#plan")  # the paper primitives PO1 runs
    assert page.locator("#missions li").count() == 1
    shot(page, "viewer.png")
    assert page.errors == []


def test_viewer_live_tree_plan_rays_replay_and_filters(server: str, browser: Any) -> None:  # noqa: F811
    empty = post(server, "fig9a-single-goal")
    done = post(server, "cluttered-field")
    wait_ended(server, empty)
    wait_ended(server, done)
    live = post(server, "cluttered-field", speed=3)  # about 70 wall seconds: time to look

    page = new_page(browser, server)
    # Opens on the latest mission, running: the tree panel shows statuses, the running action
    # highlighted; the plan is on the map with primitive ids; the rays are drawn.
    page.wait_for_selector("#tree .node.RUNNING.current", timeout=60_000)
    assert page.locator(f"#missions li.selected[data-id='{live}']").count() == 1
    tree = page.inner_text("#tree")
    assert "execute plan" in tree and "goals reached?" in tree
    statuses = page.eval_on_selector_all("#tree .node", "ns => ns.map(n => n.dataset.status)")
    assert {"RUNNING", "SUCCESS"} <= set(statuses)
    assert "(move " in page.inner_text("#tree .node.current")
    page.wait_for_function("window.viewer.drawn && window.viewer.drawn.labels.length > 0")
    drawn = page.evaluate("window.viewer.drawn")
    assert all(label.split()[1].startswith("lat-") for label in drawn["labels"])
    assert drawn["rays"] == 9 and drawn["scale"].endswith("m")
    assert page.locator("#plan li.current").count() == 1
    legend = page.inner_text("#legend")
    for entry in ("known obstacle", "sensed occupancy", "contact", "truth", "plan", "replan"):
        assert entry in legend
    rows = page.inner_text("#missions")
    assert rows.count("goals 1/1") == 2 and "replans" in rows and "ago" in rows
    assert page.is_visible("#cancel") and not page.is_visible("#replay")
    shot(page, "viewer-live.png")

    # Cancel from the viewer.
    page.click("#cancel")
    status_is(page, "cancelled")
    assert not page.is_visible("#cancel")

    # Replay the finished cluttered field: the slider moves the robot along its trajectory.
    page.click(f"#missions li[data-id='{done}']")
    status_is(page, "succeeded")
    page.wait_for_selector("#replay:not([hidden])")
    end = page.evaluate("window.viewer.pose")
    assert page.evaluate("window.viewer.world.sensed.length") > 0  # hidden obstacles were seen
    page.eval_on_selector("#slider", "s => { s.value = 60; s.dispatchEvent(new Event('input')); }")
    middle = page.evaluate("window.viewer.pose")
    assert abs(middle["t"] - 60) < 1
    assert abs(middle["x"] - end["x"]) + abs(middle["y"] - end["y"]) > 1.0
    assert "60.0 s" in page.inner_text("#slider-t")
    assert page.locator("#events li.future").count() > 0  # replans after 60 s greyed out
    page.check("#truth")
    shot(page, "viewer-replay.png")

    # Another mission: nothing of the previous one stays (its sensed cells, its events).
    page.click(f"#missions li[data-id='{empty}']")
    page.wait_for_function(
        "window.viewer.mission && window.viewer.mission.name === 'fig9a-single-goal'"
    )
    status_is(page, "succeeded")
    assert page.evaluate("window.viewer.world.sensed.length") == 0
    assert "replan trigger=path_blocked" not in page.inner_text("#events")

    # Filter by status.
    page.select_option("#filter", "cancelled")
    page.wait_for_function("document.querySelectorAll('#missions li').length === 1")
    assert page.get_attribute("#missions li", "data-status") == "cancelled"
    page.select_option("#filter", "succeeded")
    page.wait_for_function("document.querySelectorAll('#missions li').length === 2")
    assert page.errors == []


def test_viewer_asks_for_the_api_key_on_401(tmp_path: Path, browser: Any) -> None:
    proc, base = start_server(tmp_path / "key.db", SCREWSNAKE_API_KEY="s3cret")
    try:
        page = new_page(browser, base)
        page.wait_for_function("document.querySelectorAll('#example option').length > 0")
        page.select_option("#example", "fig9a-single-goal")
        page.click("#post button[type=submit]")
        page.wait_for_selector("#error:not([hidden])")
        assert "401" in page.inner_text("#error") and "API key" in page.inner_text("#error")
        shot(page, "viewer-401.png")
        page.fill("#api-key", "s3cret")
        page.click("#key-form button")
        assert not page.is_visible("#error")
        assert page.evaluate("sessionStorage.getItem('screwsnake-api-key')") == "s3cret"
        page.click("#post button[type=submit]")
        status_is(page, "succeeded")
        assert not page.is_visible("#error")
        assert page.errors == []
    finally:
        proc.terminate()
        proc.wait(timeout=20)


def test_docs_render_offline_with_every_operation_listed(server: str, browser: Any) -> None:  # noqa: F811
    """Swagger UI and ReDoc with every request to another host aborted: all from the app."""
    blocked: list[str] = []

    def only_local(route: Any) -> None:
        if route.request.url.startswith(server):
            route.continue_()
        else:
            blocked.append(route.request.url)
            route.abort()

    operations = sum(
        len([m for m in item if m in ("get", "post", "delete")])
        for item in httpx.get(server + "/openapi.json").json()["paths"].values()
    )
    page = browser.new_page(viewport={"width": 1200, "height": 800})
    console_errors: list[str] = []
    page.on("console", lambda m: console_errors.append(m.text) if m.type == "error" else None)
    page.route("**/*", only_local)
    page.goto(server + "/docs")
    page.wait_for_selector(".opblock", timeout=30_000)
    assert page.locator(".opblock").count() == operations
    text = page.inner_text("body")
    assert "/missions/{mission_id}/goals" in text and "Problem" in text
    assert not blocked, blocked  # Swagger UI asked for nothing from another host
    page.goto(server + "/redoc")
    page.wait_for_selector("text=Live updates", timeout=30_000)
    assert "/missions/{mission_id}/pause" in page.inner_text("body")
    page.close()
    assert not blocked, blocked  # ReDoc's badge too (its image is inlined)
    assert not console_errors, console_errors


def test_viewer_draws_known_maps_and_hidden_ones_with_the_truth(server: str, browser: Any) -> None:  # noqa: F811
    from tests.maps_fixtures import OFFICE_MISSION, OFFICE_YAML, office, office_map, pgm

    files = {"yaml": ("office.yaml", OFFICE_YAML.encode()), "image": ("office.pgm", pgm(office()))}
    map_id = httpx.post(f"{server}/maps", files=files, timeout=30).json()["id"]
    known = {**OFFICE_MISSION, "maps": [{"id": map_id, "known": True}]}
    first = httpx.post(f"{server}/missions", json=known, timeout=30).json()["id"]
    wait_ended(server, first)
    hidden = {**OFFICE_MISSION, "maps": [office_map(known=False, unknown_band=False)]}
    second = httpx.post(f"{server}/missions", json=hidden, timeout=30).json()["id"]
    wait_ended(server, second)

    page = new_page(browser, server)
    page.click(f"#missions li[data-id='{first}']")
    page.wait_for_function("window.viewer.drawn && window.viewer.drawn.maps.length === 1")
    assert page.evaluate("window.viewer.drawn.maps") == [{"id": map_id, "known": True}]
    assert "map: occupied / unknown" in page.inner_text("#legend")
    shot(page, "viewer-known-map.png")
    # a hidden map is the truth: drawn only with "truth" ticked
    page.click(f"#missions li[data-id='{second}']")
    page.wait_for_function("window.viewer.maps.length === 1 && !window.viewer.maps[0].known")
    assert page.evaluate("window.viewer.drawn.maps.length") == 0
    page.check("#truth")
    page.wait_for_function("window.viewer.drawn.maps.length === 1")
    assert page.evaluate("window.viewer.world.sensed.length") > 0  # its walls were sensed
    shot(page, "viewer-hidden-map.png")
    assert not page.errors

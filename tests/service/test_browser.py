"""The viewer in a real browser: Playwright driving Debian's Chromium (/usr/bin/chromium)."""

from __future__ import annotations

from pathlib import Path

import httpx
import pytest

from tests.service.test_server import server  # noqa: F401  (fixture)

CHROMIUM = Path("/usr/bin/chromium")
ARTIFACTS = Path(__file__).parents[2] / "test-artifacts"
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


@pytest.mark.skipif(
    not CHROMIUM.exists(), reason="Debian chromium is not installed (.ci/run installs it)"
)
def test_viewer_posts_a_mission_and_shows_its_end(server: str) -> None:  # noqa: F811
    sync_api = pytest.importorskip("playwright.sync_api")
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=str(CHROMIUM), args=ARGS)
        page = browser.new_page(viewport={"width": 1200, "height": 800})
        page.goto(server + "/")
        page.wait_for_function("document.querySelectorAll('#example option').length > 0")
        page.select_option("#example", "fig9b-obstacles")
        page.fill("#speed", "50")
        page.click("button[type=submit]")
        page.wait_for_function(
            "document.querySelector('#mission-status') && document.querySelector('#mission-status').textContent === 'succeeded'",
            timeout=60_000,
        )
        status = page.inner_text("#status")
        assert "fig9b-obstacles" in status and "succeeded" in status and "✓" in status
        assert "(po1 straight)" in page.inner_text("#plan")
        assert page.locator("#missions li").count() >= 1
        ARTIFACTS.mkdir(exist_ok=True)
        page.screenshot(path=str(ARTIFACTS / "viewer.png"))
        browser.close()
    assert (ARTIFACTS / "viewer.png").stat().st_size > 10_000


@pytest.mark.skipif(
    not CHROMIUM.exists(), reason="Debian chromium is not installed (.ci/run installs it)"
)
def test_docs_render_offline_with_every_operation_listed(server: str) -> None:  # noqa: F811
    """Swagger UI and ReDoc with every request to another host aborted: all from the app."""
    sync_api = pytest.importorskip("playwright.sync_api")
    blocked: list[str] = []

    def only_local(route: object) -> None:
        url = route.request.url  # type: ignore[attr-defined]
        if url.startswith(server):
            route.continue_()  # type: ignore[attr-defined]
        else:
            blocked.append(url)
            route.abort()  # type: ignore[attr-defined]

    operations = sum(
        len([m for m in item if m in ("get", "post", "delete")])
        for item in httpx.get(server + "/openapi.json").json()["paths"].values()
    )
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=str(CHROMIUM), args=ARGS)
        page = browser.new_page(viewport={"width": 1200, "height": 800})
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
        browser.close()
    # ReDoc's "API docs by Redocly" badge is an image from its CDN: decorative, and the page
    # rendered without it.
    assert set(blocked) <= {"https://cdn.redoc.ly/redoc/logo-mini.svg"}, blocked

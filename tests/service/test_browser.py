"""The viewer in a real browser: Playwright driving Debian's Chromium (/usr/bin/chromium)."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.service.test_server import server  # noqa: F401  (fixture)

CHROMIUM = Path("/usr/bin/chromium")
ARTIFACTS = Path(__file__).parents[2] / "test-artifacts"


@pytest.mark.skipif(
    not CHROMIUM.exists(), reason="Debian chromium is not installed (.ci/run installs it)"
)
def test_viewer_posts_a_mission_and_shows_its_end(server: str) -> None:  # noqa: F811
    sync_api = pytest.importorskip("playwright.sync_api")
    args = [
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-background-networking",
        "--disable-quic",
        "--no-first-run",
        "--disable-component-update",
        "--disable-sync",
    ]
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=str(CHROMIUM), args=args)
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

"""The review screen in real headless Chromium: a dispatcher works the demo day's alarm."""

from __future__ import annotations

from pathlib import Path

import httpx
import pytest

from core.database import get_sessionmaker
from core.settings import get_settings
from service.demo import load_demo
from service.setup.service import create_user
from tests.service.livekit import live_server

CHROMIUM = Path("/usr/bin/chromium")
SCREENSHOT = Path(__file__).resolve().parents[2] / "docs" / "review.png"
pytestmark = [
    pytest.mark.browser,
    pytest.mark.skipif(
        not CHROMIUM.exists(), reason="Debian chromium not installed (.ci/run installs it)"
    ),
]
CHROMIUM_ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]


def test_dispatcher_blocks_the_alarm_and_clears_another(tmp_path: Path) -> None:
    from playwright.sync_api import expect, sync_playwright

    with live_server(tmp_path) as url:
        assert load_demo(fleet=False) == 0
        with get_sessionmaker().begin() as session:
            token = create_user(session, "olena", "dispatcher")
        admin = {"Authorization": f"Bearer {get_settings().admin_token}"}
        states = {
            s["id"]: s["state"] for s in httpx.get(f"{url}/api/v1/sections", headers=admin).json()
        }
        assert states == {"AB": "alarm", "BC": "review"}, states

        with sync_playwright() as playwright:
            browser = playwright.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
            page = browser.new_page(viewport={"width": 1366, "height": 768})
            page.goto(f"{url}/review")
            page.fill("#token", token)
            page.get_by_role("button", name="Log in").click()
            expect(page.locator("#sections tr[data-section=AB] .state")).to_have_text("ALARM")

            page.click("#queue a:has-text('Section AB')")
            run = page.locator("#run")
            expect(run.locator("#verdict")).to_have_text("incomplete")
            for side in ("departure", "arrival"):
                image = run.locator(f"figure[data-side={side}] img")
                expect(image).to_be_visible()
                assert image.evaluate("img => img.complete && img.naturalWidth > 0"), side
            tables = run.locator("div.consist")
            assert tables.count() == 2, "wheel-mark and infrared consists"
            for i in range(2):
                missing = tables.nth(i).locator(".car.mark-missing")
                assert missing.count() == 2, "the two lost cars are marked"
            SCREENSHOT.parent.mkdir(exist_ok=True)
            page.screenshot(path=str(SCREENSHOT))

            keep = run.locator("form:has(input[value=keep_blocked])")
            keep.locator("textarea").fill(
                "two cars missing; section closed until the line is walked"
            )
            keep.locator("button").click()
            expect(page.locator(".notice")).to_contain_text("kept blocked")

            page.click("#queue a:has-text('Section BC')")
            clear = page.locator("#run form:has(input[value=clear])")
            clear.locator("textarea").fill("night image checked by eye: the disc is there")
            clear.locator("button").click()
            expect(page.locator(".notice")).to_contain_text("cleared")
            browser.close()

        states = {
            s["id"]: s["state"] for s in httpx.get(f"{url}/api/v1/sections", headers=admin).json()
        }
        assert states == {"AB": "blocked", "BC": "free"}, states
        audit = httpx.get(f"{url}/api/v1/audit", headers=admin).json()
        assert [(a["section"], a["action"], a["actor"]) for a in audit[:2]] == [
            ("BC", "clear", "olena"),
            ("AB", "keep_blocked", "olena"),
        ]

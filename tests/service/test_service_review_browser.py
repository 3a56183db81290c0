"""The review screen in real headless Chromium: a dispatcher works the demo day's alarm."""

from __future__ import annotations

import os
import re
from pathlib import Path

import httpx
import pytest

from core.database import get_sessionmaker
from core.settings import get_settings
from service.demo import load_demo
from service.setup.service import create_user
from tests.service.linekit import build_line
from tests.service.livekit import HTTP_TIMEOUT_S, live_client, live_server
from tests.service.reviewkit import late_photo_without_disc, review_run
from tests.service.scenario import Line

CHROMIUM = Path("/usr/bin/chromium")
# The README's picture of the review screen; a test run writes it only when asked
# (DEPOT_REVIEW_SCREENSHOT=1), so that running the suite never changes the checkout.
README_SCREENSHOT = Path(__file__).resolve().parents[2] / "docs" / "review.png"
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
            s["id"]: s["state"]
            for s in httpx.get(
                f"{url}/api/v1/sections", headers=admin, timeout=HTTP_TIMEOUT_S
            ).json()
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
            shot = README_SCREENSHOT if os.environ.get("DEPOT_REVIEW_SCREENSHOT") else None
            screenshot = page.screenshot(path=None if shot is None else str(shot))
            assert screenshot.startswith(b"\x89PNG"), "the screen can be photographed"

            page.fill("#reason", "two cars missing; section closed until the line is walked")
            page.click("#decide button[value=keep_blocked]")
            expect(page.locator(".flash-ok")).to_contain_text("kept blocked by olena")
            expect(page.locator("#decided")).to_contain_text("kept blocked by olena")

            page.click("#queue a:has-text('Section BC')")
            page.fill("#reason", "night image checked by eye: the disc is there")
            page.click("#decide button[value=clear]")
            expect(page.locator(".flash-ok")).to_contain_text("cleared by olena")
            browser.close()

        states = {
            s["id"]: s["state"]
            for s in httpx.get(
                f"{url}/api/v1/sections", headers=admin, timeout=HTTP_TIMEOUT_S
            ).json()
        }
        assert states == {"AB": "blocked", "BC": "free"}, states
        audit = httpx.get(f"{url}/api/v1/audit", headers=admin, timeout=HTTP_TIMEOUT_S).json()
        assert [(a["section"], a["action"], a["actor"]) for a in audit[:2]] == [
            ("BC", "clear", "olena"),
            ("AB", "keep_blocked", "olena"),
        ]


PERIOD_S = 2  # DEPOT_REVIEW_REFRESH_S in the live test: its smallest allowed value
SLACK_MS = 1500  # one request's time on a loaded 2-core machine


def test_screen_updates_in_place_keeps_the_draft_alerts_and_turns_stale(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 17: an alarm arriving while a reason is typed shows within one period with the
    draft kept, sounds and notifies; Clear asks first on an alarm; a stopped server is shown."""
    from playwright.sync_api import expect, sync_playwright

    monkeypatch.setenv("DEPOT_REVIEW_REFRESH_S", str(PERIOD_S))
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(
            executable_path=str(CHROMIUM),
            args=[*CHROMIUM_ARGS, "--autoplay-policy=no-user-gesture-required"],
        )
        context = browser.new_context(viewport={"width": 1366, "height": 768})
        page = context.new_page()
        with live_server(tmp_path) as url, live_client(url) as http:
            context.grant_permissions(["notifications"], origin=url)
            line = Line(http, build_line(http))  # type: ignore[arg-type]
            run = review_run(line)
            with get_sessionmaker().begin() as session:
                token = create_user(session, "olena", "dispatcher")
            page.goto(f"{url}/review")
            page.fill("#token", token)
            page.get_by_role("button", name="Log in").click()
            section = page.locator("#sections tr[data-section=AB]")
            expect(section).to_have_attribute("data-state", "review")
            expect(page.locator("#updated")).to_have_text(re.compile(r"updated \d\d:\d\d:\d\d"))
            page.click("#sound")
            expect(page.locator("#sound")).to_have_attribute("aria-pressed", "true")
            # the click plays the chime once: the test of the sound, and the unlock
            expect(page.locator("body")).to_have_attribute("data-sounded", "1")

            page.fill("#reason", "checking with B")
            page.click("h1")  # the box is left with the draft in it, as in the issue
            late_photo_without_disc(line)
            within = PERIOD_S * 1000 + SLACK_MS
            expect(section).to_have_attribute("data-state", "alarm", timeout=within)
            expect(page.locator("#reason")).to_have_value("checking with B")
            expect(page).to_have_title(re.compile(r"^ALARM AB"))
            alarm_row = page.locator(f"#queue tr.item-alarm[data-run='{run}']")
            expect(alarm_row.locator(".since")).to_contain_text("in alarm for")
            expect(page.locator("body")).to_have_attribute("data-alerts", "1")
            expect(page.locator("body")).to_have_attribute("data-notified", "1")
            expect(page.locator("body")).to_have_attribute("data-sounded", "2")

            buttons = page.locator("#decide button[name=action]")
            expect(buttons.first).to_have_attribute("value", "keep_blocked")
            page.once("dialog", lambda dialog: dialog.dismiss())
            page.click("#decide button[value=clear]")
            expect(page.locator("#reason")).to_have_value("checking with B")  # not sent
            assert line.section()["state"] == "alarm"
            page.fill("#reason", "B confirms the last car is missing")
            page.click("#decide button[value=keep_blocked]")
            expect(page.locator(".flash-ok")).to_contain_text("kept blocked by olena")
            expect(page.locator("#decide button[value=keep_blocked]")).to_have_count(0)
            expect(page.locator("body")).not_to_have_class(re.compile("stale"))
        # the server is stopped: within twice the period the page must say it is stale
        expect(page.locator("#stale-banner")).to_be_visible(timeout=2 * within + 1000)
        expect(page.locator("body")).to_have_class(re.compile("stale"))
        # and its decisions wait until it is current again (found by the second trial)
        assert page.locator("button.act").count() > 0
        for button in page.locator("button.act").all():
            expect(button).to_be_disabled()
        browser.close()


FOLD_PX = 768  # the dispatcher's laptop: 1366×768, nothing scrolled


def test_the_queue_is_the_first_thing_seen_on_a_long_line(tmp_path: Path) -> None:
    """An independent trial: with a line of many sections the queue of sections needing a
    person was below the fold at 1366×768 (under the list of every section), and its heading
    said "oldest first" while it is most urgent first."""
    from playwright.sync_api import expect, sync_playwright

    with live_server(tmp_path) as url, live_client(url) as http:
        line = Line(http, build_line(http))  # type: ignore[arg-type]
        admin = {"Authorization": f"Bearer {get_settings().admin_token}"}
        for i in range(30):
            station = {"id": f"S{i:02}", "name": f"Station {i}"}
            assert http.post("/api/v1/stations", json=station, headers=admin).status_code == 201
            section = {"id": f"Z{i:02}", "from_station": "C", "to_station": f"S{i:02}"}
            assert http.post("/api/v1/sections", json=section, headers=admin).status_code == 201
        run = review_run(line)
        with get_sessionmaker().begin() as session:
            token = create_user(session, "olena", "dispatcher")
        with sync_playwright() as playwright:
            browser = playwright.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
            page = browser.new_page(viewport={"width": 1366, "height": FOLD_PX})
            page.goto(f"{url}/review")
            page.fill("#token", token)
            page.get_by_role("button", name="Log in").click()
            item = page.locator(f"#queue tr.item[data-run='{run}']")
            expect(item).to_be_visible()
            box = item.bounding_box()
            assert box is not None
            assert box["y"] >= 0 and box["y"] + box["height"] <= FOLD_PX, box
            heading = page.locator("#frag-queue h2")
            expect(heading).to_contain_text("most urgent first")
            expect(heading).not_to_contain_text("oldest first")
            browser.close()

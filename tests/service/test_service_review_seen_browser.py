"""The review screen in real headless Chromium acts only on what it shows (an independent trial,
F2): a clear clicked on a page drawn before a late proof of loss is refused, the page shows the
run as it is now with the typed reason kept, and the section stays in ALARM; a page that stopped
updating (the red banner) sends no decision at all."""

from __future__ import annotations

import re
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import httpx
import pytest

from core.database import get_sessionmaker
from core.settings import get_settings
from service.setup.service import create_user
from tests.service.linekit import build_line
from tests.service.livekit import HTTP_TIMEOUT_S, live_client, live_server
from tests.service.reviewkit import late_photo_without_disc, review_run
from tests.service.scenario import Line
from tests.service.test_service_review_browser import CHROMIUM, CHROMIUM_ARGS

pytestmark = [
    pytest.mark.browser,
    pytest.mark.skipif(
        not CHROMIUM.exists(), reason="Debian chromium not installed (.ci/run installs it)"
    ),
]
# Long enough that the page cannot refresh by itself between drawing the run and the click:
# the click is on the old page, as in the trial.
SLOW_PERIOD_S = 600
PERIOD_S = 2  # for the stale page: its smallest allowed value
REASON = "camera image looked ok to me"


def _audit(url: str) -> list[dict[str, Any]]:
    admin = {"Authorization": f"Bearer {get_settings().admin_token}"}
    answer: list[dict[str, Any]] = httpx.get(
        f"{url}/api/v1/audit", headers=admin, timeout=HTTP_TIMEOUT_S
    ).json()
    return answer


def _login(page: Any, url: str) -> None:
    with get_sessionmaker().begin() as session:
        token = create_user(session, "olena", "dispatcher")
    page.goto(f"{url}/review")
    page.fill("#token", token)
    page.get_by_role("button", name="Log in").click()


@contextmanager
def _review_page(tmp_path: Path) -> Iterator[tuple[str, Line, int, Any]]:
    """A live server with a run under review, and a Chromium page (not yet logged in):
    (url, line, run id, page). Set ``DEPOT_REVIEW_REFRESH_S`` first."""
    from playwright.sync_api import sync_playwright

    with (
        live_server(tmp_path) as url,
        live_client(url) as http,
        sync_playwright() as playwright,
    ):
        line = Line(http, build_line(http))  # type: ignore[arg-type]
        run = review_run(line)
        browser = playwright.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
        page = browser.new_page(viewport={"width": 1366, "height": 900})
        try:
            yield url, line, run, page
        finally:
            browser.close()


def test_a_clear_from_a_page_drawn_before_the_alarm_is_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from playwright.sync_api import expect

    monkeypatch.setenv("DEPOT_REVIEW_REFRESH_S", str(SLOW_PERIOD_S))
    with _review_page(tmp_path) as (url, line, run, page):
        dialogs: list[str] = []

        def answer(dialog: Any) -> None:
            dialogs.append(dialog.message)
            dialog.accept()

        page.on("dialog", answer)
        _login(page, url)
        page.goto(f"{url}/review?run={run}")
        expect(page.locator("#verdict")).to_have_text("undetermined")
        page.fill("#reason", REASON)
        late_photo_without_disc(line)  # meanwhile: proof of a loss
        assert line.section()["state"] == "alarm"

        page.click("#decide button[value=clear]")
        refusal = page.locator("#decision-refusal")
        expect(refusal).to_be_visible()
        expect(refusal).to_contain_text("the run changed since you looked")
        expect(refusal).to_contain_text("section now ALARM")
        # the run is read again in place: the new verdict, the alarm, the reason kept
        expect(page.locator("#verdict")).to_have_text("incomplete")
        expect(page.locator("#sections tr[data-section=AB]")).to_have_attribute(
            "data-state", "alarm"
        )
        expect(page.locator("#reason")).to_have_value(REASON)
        assert page.url == f"{url}/review?run={run}"
        assert dialogs == [], "the page drawn under review asked nothing before the clear"
        assert line.section()["state"] == "alarm"
        assert _audit(url) == []

        # on the page as it is now, the decision goes through (alarm: keep blocked first)
        expect(page.locator("#decide button[name=action]").first).to_have_attribute(
            "value", "keep_blocked"
        )
        page.fill("#reason", "B confirms the last car is missing")
        page.click("#decide button[value=keep_blocked]")
        expect(page.locator(".flash-ok")).to_contain_text("kept blocked by olena")
        assert line.section()["state"] == "blocked"
        assert [a["action"] for a in _audit(url)] == ["keep_blocked"]


def test_a_stale_page_sends_no_decision(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from playwright.sync_api import expect

    monkeypatch.setenv("DEPOT_REVIEW_REFRESH_S", str(PERIOD_S))
    with _review_page(tmp_path) as (url, line, run, page):
        _login(page, url)
        page.goto(f"{url}/review?run={run}")
        page.fill("#reason", REASON)
        # the screen's updates stop reaching the server (the link, not the server, is down)
        page.route(re.compile(r"/review/live"), lambda route: route.abort())
        expect(page.locator("#stale-banner")).to_be_visible(timeout=4 * PERIOD_S * 1000 + 3000)
        buttons = page.locator("#decide button.act")
        assert buttons.count() > 0
        for button in buttons.all():
            expect(button).to_be_disabled()
        # a submission by any other way (Enter, a script) is not sent either
        page.evaluate("document.getElementById('decide').requestSubmit()")
        expect(page.locator("#decision-refusal")).to_contain_text("not current: nothing was sent")
        assert line.section()["state"] == "review"
        assert _audit(url) == []

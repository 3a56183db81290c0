"""``/docs`` and ``/redoc`` in real headless Chromium with every non-local request blocked:
railway networks are often isolated, so the documentation must come from the app itself."""

from __future__ import annotations

from pathlib import Path
from urllib.parse import urlsplit

import pytest

from tests.service.livekit import live_server
from tests.service.test_service_review_browser import CHROMIUM, CHROMIUM_ARGS

pytestmark = [
    pytest.mark.browser,
    pytest.mark.skipif(
        not CHROMIUM.exists(), reason="Debian chromium not installed (.ci/run installs it)"
    ),
]
LOCAL_HOSTS = {"127.0.0.1", "localhost"}


def test_docs_render_with_the_network_blocked(tmp_path: Path) -> None:
    from playwright.sync_api import Route, expect, sync_playwright

    blocked: list[str] = []

    def only_local(route: Route) -> None:
        url = route.request.url
        if url.startswith(("data:", "blob:")) or urlsplit(url).hostname in LOCAL_HOSTS:
            route.continue_()
        else:
            blocked.append(url)
            route.abort("internetdisconnected")

    with live_server(tmp_path) as url, sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
        context = browser.new_context()
        context.route("**/*", only_local)
        page = context.new_page()

        page.goto(f"{url}/docs")
        operations = page.locator(".opblock")
        expect(operations.first).to_be_visible(timeout=20_000)
        assert operations.count() > 20, "every API operation is listed"
        upload = page.locator(".opblock-post .opblock-summary-path[data-path='/api/v1/snapshots']")
        expect(upload).to_be_visible()
        upload.click()  # the documented multipart form is rendered with its fields
        expect(page.locator(".opblock-post.is-open")).to_contain_text("occurred_at")

        page.goto(f"{url}/redoc")
        expect(page.get_by_text("/api/v1/events").first).to_be_attached(timeout=20_000)
        browser.close()
    assert blocked == [], f"the docs asked the internet for {blocked}"


def test_the_snapshot_upload_has_a_documented_form() -> None:
    from fastapi.testclient import TestClient

    from service.app import create_app

    document = TestClient(create_app()).get("/openapi.json").json()
    body = document["paths"]["/api/v1/snapshots"]["post"]["requestBody"]
    form = body["content"]["multipart/form-data"]["schema"]
    assert form == {"$ref": "#/components/schemas/SnapshotUpload"}
    upload = document["components"]["schemas"]["SnapshotUpload"]
    assert set(upload["required"]) == {"image", "event_id", "occurred_at", "section"}
    assert upload["properties"]["image"]["format"] == "binary"
    assert upload["properties"]["occurred_at"]["format"] == "date-time"

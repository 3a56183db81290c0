"""``GET /metrics``: Prometheus text with events by kind and outcome, decision latency,
stale devices and the review queue; only for the admin or the metrics token."""

from __future__ import annotations

import re

import pytest
from fastapi.testclient import TestClient
from sqlalchemy.orm import Session

from core import metrics
from core.database import utcnow
from core.settings import get_settings
from tests.conftest import ADMIN
from tests.service.linekit import DEVICES, build_line, event
from tests.service.scenario import jpeg

SAMPLE = re.compile(r"^([a-z_]+)(\{[^}]*\})? (\S+)$")


def _scrape(client: TestClient, headers: dict[str, str] = ADMIN) -> dict[str, float]:
    answer = client.get("/metrics", headers=headers)
    assert answer.status_code == 200, answer.text
    assert answer.headers["content-type"].startswith("text/plain; version=0.0.4")
    samples: dict[str, float] = {}
    for line in answer.text.splitlines():
        if line.startswith("#"):
            assert re.match(r"^# (HELP|TYPE) [a-z_]+ .+$", line), line
            continue
        match = SAMPLE.match(line)
        assert match, f"not Prometheus text: {line!r}"
        samples[match[1] + (match[2] or "")] = float(match[3])
    return samples


def test_metrics_count_events_decisions_and_stale_devices(client: TestClient) -> None:
    keys = build_line(client)
    before = _scrape(client)
    axles = event("m-ac-1", "axle_count", section="AB", axles=16)
    assert client.post("/api/v1/events", json=axles, headers=keys["A-ac"]).status_code == 201
    assert client.post("/api/v1/events", json=axles, headers=keys["A-ac"]).status_code == 200
    wrong = event("m-ac-2", "axle_count", section="BC", axles=16)  # not its section
    assert client.post("/api/v1/events", json=wrong, headers=keys["A-ac"]).status_code == 422
    departed = event("m-d", "train_departed", section="AB", train="77")
    arrived = event("m-a", "train_arrived", at="2026-11-23T10:40:00Z", section="AB", train="77")
    assert client.post("/api/v1/events", json=departed, headers=keys["A-ilk"]).status_code == 201
    assert client.post("/api/v1/events", json=arrived, headers=keys["B-ilk"]).status_code == 201
    now = utcnow().isoformat()
    batch = {"events": [event("m-b1", "heartbeat", at=now), {"kind": "heartbeat"}]}
    assert client.post("/api/v1/events", json=batch, headers=keys["A-cam"]).status_code == 200
    after = _scrape(client)

    def delta(name: str) -> float:
        return after.get(name, 0.0) - before.get(name, 0.0)

    series = 'depot_events_total{{kind="{}",outcome="{}",status="{}"}}'
    assert delta(series.format("axle_count", "accepted", 201)) == 1
    assert delta(series.format("axle_count", "duplicate", 200)) == 1
    assert delta(series.format("axle_count", "refused", 422)) == 1
    assert delta(series.format("heartbeat", "accepted", 201)) == 1
    assert delta(series.format("heartbeat", "refused", 422)) == 1
    assert delta("depot_decision_seconds_count") == 1
    assert delta('depot_decision_seconds_bucket{le="+Inf"}') == 1
    occasional = {"marking_station", "test_bench", "onboard_unit"}
    watched = [d for d, _, _, kind in DEVICES if kind not in occasional]
    # liveness counts the server's receive times: the four devices heard here are fresh
    heard = {"A-ac", "A-ilk", "B-ilk", "A-cam"}
    assert after["depot_devices_stale"] == len(set(watched) - heard)
    sections = {k: v for k, v in after.items() if k.startswith("depot_sections{")}
    assert sum(sections.values()) == 2, sections  # AB and BC, each in one state
    assert after["depot_review_queue"] == sum(
        v
        for k, v in sections.items()
        if re.search('"(alarm|review|awaiting_confirmation|blocked)"', k)
    )


def test_metrics_need_the_admin_or_the_metrics_token(
    client: TestClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    assert client.get("/metrics").status_code == 401
    assert client.get("/metrics", headers={"Authorization": "Bearer nope"}).status_code == 401
    token = "m" * 32
    monkeypatch.setenv("DEPOT_METRICS_TOKEN", token)
    get_settings.cache_clear()
    try:
        assert (
            "depot_events_total"
            in client.get("/metrics", headers={"Authorization": f"Bearer {token}"}).text
        )
    finally:
        monkeypatch.delenv("DEPOT_METRICS_TOKEN")
        get_settings.cache_clear()


def test_hostile_kinds_cannot_grow_the_answer() -> None:
    counter = metrics.Counter("t_total", "test", ("kind",))
    for i in range(metrics.MAX_SERIES + 50):
        counter.inc(f"kind{i}")
    assert len(counter.render()) == 2 + metrics.MAX_SERIES + 1  # help, type, series, "other"
    assert counter.value("other") == 50
    assert metrics._kind_of({"kind": 'x"}\n'}) == "unknown"


def test_stale_devices_gauge_follows_the_one_liveness_rule(
    client: TestClient, session: Session, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``depot_devices_stale`` counts what ``ingest.liveness`` calls stale and the review
    screen lists, not a query of its own: change the rule in one place and both follow."""
    from datetime import datetime

    from ingest import liveness
    from service.review.service import stale_devices

    build_line(client)
    shown = len(stale_devices(session, utcnow()))
    assert _scrape(client)["depot_devices_stale"] == shown > 0

    def nobody_is_silent(last_received: datetime | None, now: datetime) -> bool:
        return False

    monkeypatch.setattr(liveness, "silent", nobody_is_silent)
    assert stale_devices(session, utcnow()) == []
    assert _scrape(client)["depot_devices_stale"] == 0


def test_metrics_count_snapshot_uploads_too(client: TestClient) -> None:
    """A snapshot is a device event like any other (an independent trial: uploads were not
    counted): accepted, retried and refused ones each count under ``tail_snapshot``."""
    keys = build_line(client)
    image = jpeg(disc=True, seed=4)
    form = {"event_id": "m-s1", "occurred_at": "2026-11-23T10:41:00Z", "section": "AB"}
    before = _scrape(client)
    for data, status in ((image, 201), (image, 200), (b"not an image", 422)):
        event_id = form["event_id"] if status != 422 else "m-s2"
        files = {"image": ("t.jpg", data, "image/jpeg")}
        answer = client.post(
            "/api/v1/snapshots", data={**form, "event_id": event_id}, files=files,
            headers=keys["B-cam"],
        )  # fmt: skip
        assert answer.status_code == status, answer.text
    after = _scrape(client)
    series = 'depot_events_total{{kind="tail_snapshot",outcome="{}",status="{}"}}'
    for outcome, status in (("accepted", 201), ("duplicate", 200), ("refused", 422)):
        name = series.format(outcome, status)
        assert after.get(name, 0.0) - before.get(name, 0.0) == 1, name

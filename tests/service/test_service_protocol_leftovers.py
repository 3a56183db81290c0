"""Protocol leftovers (protocol.md): a batch item that is not an object is rejected alone,
the others stored ("each item stands alone"); a ``/snapshots`` form field the protocol does
not name is refused with 422 naming it, as an unknown field of an event is."""

from __future__ import annotations

from typing import Any

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import func, select
from sqlalchemy.orm import Session

from ingest.batches import batch_events
from ingest.models import RawEvent, Snapshot
from tests.service.linekit import build_line, event
from tests.service.scenario import jpeg


def _raw_count(session: Session) -> int:
    return session.scalar(select(func.count()).select_from(RawEvent)) or 0


def test_a_batch_item_that_is_not_an_object_is_rejected_alone(
    client: TestClient, session: Session
) -> None:
    keys = build_line(client)
    items: list[Any] = [
        event("hb-1", "heartbeat"),
        5,
        "heartbeat",
        None,
        [],
        event("hb-2", "heartbeat"),
    ]
    answer = client.post("/api/v1/events", json={"events": items}, headers=keys["B-ac"])
    assert answer.status_code == 200, answer.text
    results = answer.json()["results"]
    assert [r["status"] for r in results] == ["created"] + ["rejected"] * 4 + ["created"]
    for rejected in results[1:5]:
        assert rejected["event_id"] is None
        assert rejected["error"]["status"] == 422
        assert "must be a JSON object" in rejected["error"]["detail"], rejected
    assert _raw_count(session) == 2


def test_the_batch_shape_is_still_refused_whole() -> None:
    """What is not a batch of 1 to 1000 items is refused as a whole (every transport)."""

    from core.errors import Unprocessable

    assert batch_events({"events": [1, {"kind": "heartbeat"}]}) == [1, {"kind": "heartbeat"}]
    assert batch_events({"kind": "heartbeat"}) is None
    for shape in (
        {"events": []},
        {"events": [{}] * 1001},
        {"events": {}},
        {"events": [{}], "x": 1},
    ):
        with pytest.raises(Unprocessable, match="invalid batch"):
            batch_events(shape)


def test_a_snapshot_form_field_the_protocol_does_not_name_is_refused() -> None:
    """protocol.md names the form fields event_id, occurred_at, section and the file image; an
    event refuses an unknown field (422), so does the snapshot form, naming the field (a
    ``camera`` or ``occured_at`` field silently dropped leaves its integrator unaware)."""

    from core.errors import Unprocessable
    from ingest.snapshots import check_form_fields

    check_form_fields(["event_id", "occurred_at", "section", "image"])
    check_form_fields(["image", "section"])  # a missing field is said by its own check
    with pytest.raises(Unprocessable) as refused:
        check_form_fields(["event_id", "occurred_at", "section", "image", "occured_at", "camera"])
    assert "'camera', 'occured_at'" in refused.value.detail
    assert "event_id, occurred_at, section and the file image" in refused.value.detail
    assert [e["loc"] for e in refused.value.errors or []] == [
        ["body", "camera"],
        ["body", "occured_at"],
    ]


def test_the_snapshot_upload_names_an_unknown_form_field(
    client: TestClient, session: Session
) -> None:
    keys = build_line(client)
    form = {
        "event_id": "s-x",
        "occurred_at": "2026-11-23T10:41:00Z",
        "section": "AB",
        "camera": "B-cam-2",
    }
    files = {"image": ("tail.jpg", jpeg(disc=True), "image/jpeg")}
    answer = client.post("/api/v1/snapshots", data=form, files=files, headers=keys["B-cam"])
    assert answer.status_code == 422, answer.text
    assert answer.headers["content-type"] == "application/problem+json"
    assert "'camera'" in answer.json()["detail"]
    assert answer.json()["errors"] == [{"loc": ["body", "camera"], "msg": "unknown form field"}]
    assert session.scalar(select(func.count()).select_from(Snapshot)) == 0
    assert _raw_count(session) == 0

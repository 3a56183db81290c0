"""Protocol leftovers (protocol.md): a batch item that is not an object is rejected alone,
the others stored ("each item stands alone"); a ``/snapshots`` form field the protocol does
not name is refused with 422 naming it, as an unknown field of an event is."""

from __future__ import annotations

from typing import Any

from fastapi.testclient import TestClient
from sqlalchemy import func, select
from sqlalchemy.orm import Session

from ingest.batches import batch_events
from ingest.models import RawEvent
from tests.service.linekit import build_line, event


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
    import pytest

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

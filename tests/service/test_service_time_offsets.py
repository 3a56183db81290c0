"""UTC offsets of device times: the world's time zones run from -12:00 to +14:00.

An independent trial sent ``+16:00`` (valid ISO 8601 text, the same instant as a normal
time): it passed validation and then failed in PostgreSQL (whose offsets stop at ±15:59) with
a 422 naming no field, and in a batch that one item took the batch down, a good
``train_departed`` with it, so the section the train had entered stayed ``free``.
"""

from __future__ import annotations

from datetime import timedelta
from typing import Any

import pytest
from fastapi.testclient import TestClient
from pydantic import ValidationError
from sqlalchemy import select
from sqlalchemy.orm import Session

from core.models import Section
from ingest.models import RawEvent
from ingest.schemas import EVENT_ADAPTER
from tests.service.linekit import build_line, event

EVENTS = "/api/v1/events"
ZONES_ACCEPTED = ("+14:00", "-12:00", "+05:45", "-09:30", "+00:00", "Z")
OFFSETS_REFUSED = ("+16:00", "-16:00", "-23:59", "+15:00", "-13:00", "+14:01")


@pytest.mark.parametrize("offset", ZONES_ACCEPTED)
def test_every_time_zone_of_the_world_is_accepted(offset: str) -> None:
    at = EVENT_ADAPTER.validate_python(
        event("z", "heartbeat", at=f"2026-11-23T10:15:00{offset}")
    ).occurred_at
    assert at.utcoffset() is not None


@pytest.mark.parametrize("offset", OFFSETS_REFUSED)
def test_an_offset_no_time_zone_has_is_refused_by_name(offset: str) -> None:
    with pytest.raises(ValidationError) as caught:
        EVENT_ADAPTER.validate_python(event("z", "heartbeat", at=f"2026-11-23T10:15:00{offset}"))
    (error,) = caught.value.errors()
    assert error["loc"][-1] == "occurred_at"
    assert "-12:00" in error["msg"] and "+14:00" in error["msg"], error["msg"]


@pytest.mark.parametrize("offset", ("+16:00", "-23:59"))
def test_one_odd_offset_in_a_batch_leaves_the_departure_stored(
    offset: str, client: TestClient, session: Session
) -> None:
    keys = build_line(client)
    items: list[Any] = [
        event("off-dep", "train_departed", section="AB", train="2041"),
        event("off-hb", "heartbeat", at=f"2026-11-23T21:54:55.957129{offset}"),
    ]
    response = client.post(EVENTS, json={"events": items}, headers=keys["A-ilk"])
    assert response.status_code == 200, response.text
    departure, heartbeat = response.json()["results"]
    assert departure["status"] == "created"
    assert heartbeat["status"] == "rejected" and heartbeat["error"]["status"] == 422
    assert heartbeat["error"]["errors"][0]["loc"] == ["body", "occurred_at"]
    stored = session.scalars(select(RawEvent.event_id).where(RawEvent.event_id.like("off-%")))
    assert list(stored) == ["off-dep"]
    section = session.get_one(Section, "AB")
    session.refresh(section)
    assert section.state != "free"


def test_a_single_event_with_an_odd_offset_names_the_field(client: TestClient) -> None:
    keys = build_line(client)
    body = event("off-1", "heartbeat", at="2026-11-23T10:15:00+16:00")
    response = client.post(EVENTS, json=body, headers=keys["B-ac"])
    assert response.status_code == 422, response.text
    assert response.headers["content-type"] == "application/problem+json"
    assert response.json()["errors"][0]["loc"] == ["body", "occurred_at"]


def test_a_value_only_the_database_refuses_rejects_its_item_alone(
    client: TestClient, session: Session, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Defence in depth: a value the validation lets through and the database refuses (here
    the offsets, with the validation's bounds widened) rejects its own item, and the batch's
    other items are stored and derived."""
    if session.get_bind().dialect.name != "postgresql":
        pytest.skip("SQLite stores any offset: the database refuses nothing here")
    monkeypatch.setattr("ingest.field_types.EASTMOST_OFFSET", timedelta(hours=23, minutes=59))
    keys = build_line(client)
    items: list[Any] = [
        event("db-dep", "train_departed", section="AB", train="2041"),
        event("db-hb", "heartbeat", at="2026-11-23T21:54:55+16:00"),
        event("db-hb2", "heartbeat"),
    ]
    response = client.post(EVENTS, json={"events": items}, headers=keys["A-ilk"])
    assert response.status_code == 200, response.text
    statuses = [r["status"] for r in response.json()["results"]]
    assert statuses == ["created", "rejected", "created"]
    refusal = response.json()["results"][1]["error"]
    assert refusal["status"] == 422 and "cannot be stored" in refusal["detail"], refusal
    stored = session.scalars(select(RawEvent.event_id).where(RawEvent.event_id.like("db-%")))
    assert sorted(stored) == ["db-dep", "db-hb2"]
    section = session.get_one(Section, "AB")
    session.refresh(section)
    assert section.state != "free"

"""Device payloads an independent trial found unsafe: text no column can store, numbers too
long to read, and a key look-up that held a database connection while a body trickled in."""

from __future__ import annotations

import asyncio
from typing import Any

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import func, select
from sqlalchemy.exc import DataError
from sqlalchemy.orm import Session
from starlette.requests import Request

from core.auth import get_principal
from core.errors import DepotError
from ingest.models import RawEvent
from ingest.router import _read_limited
from ingest.store import derive_error_text
from tests.conftest import ADMIN
from tests.service.linekit import build_line, event

PROBLEM = "application/problem+json"


def _departure(event_id: str, train: str) -> dict[str, Any]:
    return event(event_id, "train_departed", section="AB", train=train)


def _stored(session: Session, event_id: str) -> int:
    return session.scalar(select(func.count()).where(RawEvent.event_id == event_id)) or 0


@pytest.mark.parametrize("train", ["\u0000", "20\u000041"])
def test_a_nul_in_a_train_number_is_refused_naming_the_field(
    client: TestClient, session: Session, train: str
) -> None:
    """Stored, it could not be derived: the departure was acknowledged and its section stayed
    free. Refused before anything is stored, the device hears which field is wrong."""
    keys = build_line(client)
    response = client.post("/api/v1/events", json=_departure("nul-1", train), headers=keys["A-ilk"])
    assert response.status_code == 422, response.text
    assert response.headers["content-type"].startswith(PROBLEM)
    assert response.json()["errors"][0]["loc"] == ["body", "train"]
    assert _stored(session, "nul-1") == 0
    section = client.get("/api/v1/sections/AB", headers=ADMIN).json()
    assert section["state"] == "free"  # nothing was accepted that could occupy it


def test_a_nul_in_one_batch_item_refuses_that_item_only(
    client: TestClient, session: Session
) -> None:
    keys = build_line(client)
    items = [
        event("nb-1", "heartbeat"),
        _departure("nb-2", "\u0000x"),
        event("nb-3", "heartbeat", measured={"door\u0000": 1.0}),
        event("nb-4", "heartbeat"),
    ]
    response = client.post("/api/v1/events", json={"events": items}, headers=keys["A-ilk"])
    assert response.status_code == 200, response.text
    results = response.json()["results"]
    assert [r["status"] for r in results] == ["created", "rejected", "rejected", "created"]
    assert results[1]["error"]["errors"][0]["loc"] == ["body", "train"]
    assert _stored(session, "nb-1") == _stored(session, "nb-4") == 1


@pytest.mark.parametrize("path", ["/api/v1/events", "/api/v1/stations"])
def test_a_number_of_thousands_of_digits_is_refused_not_a_server_error(
    client: TestClient, path: str
) -> None:
    keys = build_line(client)
    digits = "9" * 5000
    if path.endswith("events"):
        body = (
            '{"event_id":"big","occurred_at":"2026-11-23T10:15:00Z","kind":"axle_count",'
            f'"section":"AB","axles":{digits}}}'
        )
        headers = keys["A-ac"]
    else:
        body = f'{{"id":"Z","name":"Z","km":{digits}}}'
        headers = ADMIN
    response = client.post(
        path, content=body, headers={**headers, "Content-Type": "application/json"}
    )
    assert response.status_code == 422, response.text
    assert response.headers["content-type"].startswith(PROBLEM)
    assert "4300 digits" in response.json()["detail"]


def test_a_device_key_look_up_holds_no_transaction_afterwards(
    client: TestClient, session: Session
) -> None:
    """What a request does after authenticating (reading a large body) holds no pooled
    connection for the look-up."""
    keys = build_line(client)
    session.commit()
    principal = get_principal(session, None, keys["A-cam"]["X-Device-Key"])
    assert principal.role == "device"
    assert not session.in_transaction()


def test_an_event_without_a_kind_is_told_the_field_is_missing(client: TestClient) -> None:
    keys = build_line(client)
    body = {"event_id": "nk", "occurred_at": "2026-11-23T10:15:00Z"}
    response = client.post("/api/v1/events", json=body, headers=keys["A-ac"])
    assert response.status_code == 422
    assert "'kind' is missing" in response.json()["detail"]


def test_a_failed_derivation_is_reported_without_the_sql() -> None:
    """The device and the event log hear the error, not the statement and its parameters."""
    orig = ValueError("PostgreSQL text fields cannot contain NUL (0x00) bytes\nmore")
    exc = DataError("INSERT INTO runs (id, train) VALUES (%(id)s, %(train)s)", {"id": 1}, orig)
    text = derive_error_text(exc)
    assert text == "DataError: PostgreSQL text fields cannot contain NUL (0x00) bytes"
    assert derive_error_text(KeyError("x")) == "KeyError: 'x'"


def test_a_client_gone_before_its_body_arrived_is_a_refusal_not_a_traceback() -> None:
    """Starlette raises ClientDisconnect, which the server logged as an ASGI error with its
    traceback, once per such request; now it is a refusal nobody hears (nothing stored)."""

    async def receive() -> dict[str, Any]:
        return {"type": "http.disconnect"}

    request = Request({"type": "http", "method": "POST", "headers": []}, receive)
    with pytest.raises(DepotError, match="closed the connection"):
        asyncio.run(_read_limited(request, 1000))

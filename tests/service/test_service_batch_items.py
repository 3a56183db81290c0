"""Batches item by item: retries inside a batch, mixed valid and invalid items, a batch that
repeats stored events, and the rows the one-statement insert writes (on SQLite and PostgreSQL).

The batch path validates its items in one pass and inserts them with one statement; these tests
hold it to the answers and rows the single-event path gives, item by item.
"""

from __future__ import annotations

import hashlib
import json
from datetime import UTC, datetime, timedelta
from typing import Any

from fastapi.testclient import TestClient
from sqlalchemy import func, select
from sqlalchemy.orm import Session

from ingest.models import RawEvent
from ingest.schemas import EVENT_ADAPTER
from tests.service.linekit import build_line, event

EVENTS = "/api/v1/events"


def _results(client: TestClient, headers: dict[str, str], items: list[Any]) -> list[Any]:
    response = client.post(EVENTS, json={"events": items}, headers=headers)
    assert response.status_code == 200, response.text
    assert response.headers["content-type"] == "application/json"
    results: list[Any] = response.json()["results"]
    assert len(results) == len(items)
    return results


def _stored(session: Session, prefix: str) -> list[RawEvent]:
    return list(
        session.scalars(
            select(RawEvent).where(RawEvent.event_id.like(f"{prefix}%")).order_by(RawEvent.id)
        )
    )


def test_a_retry_inside_a_batch_is_answered_as_its_original(
    client: TestClient, session: Session
) -> None:
    """The same event twice in one batch (a device that resends before the answer came):
    stored once, the repeat answered with the original's result; the same id with another
    body in the same batch is refused, whichever spelling the repeat uses."""
    keys = build_line(client)
    count = event("in-1", "axle_count", section="AB", axles=8)
    items = [
        count,
        event("in-2", "heartbeat"),
        {**count, "occurred_at": "2026-11-23T12:15:00+02:00", "axles": 8.0},  # same event
        {**count, "axles": 12},  # another event under a used id
    ]
    results = _results(client, keys["B-ac"], items)
    assert [r["status"] for r in results] == ["created", "created", "duplicate", "rejected"]
    assert results[2]["result"] == {**results[0]["result"], "status": "duplicate"}
    assert results[3]["error"]["status"] == 409 and results[3]["event_id"] == "in-1"
    assert [r.event_id for r in _stored(session, "in-")] == ["in-1", "in-2"]


def test_mixed_valid_and_invalid_items_are_judged_alone(
    client: TestClient, session: Session
) -> None:
    """One invalid item makes the one-pass validation fail; each item is then judged alone,
    with the same answers the single-event path gives, and the valid ones are stored."""
    keys = build_line(client)
    ahead = (datetime.now(UTC) + timedelta(days=3)).isoformat()
    items: list[Any] = [
        event("mix-1", "heartbeat"),
        event("mix-2", "axle_count", section="AB", axles="12"),  # wrong JSON type
        {"event_id": "mix-3", "kind": "teleport", "occurred_at": "2026-11-23T10:15:00Z"},
        "not an event",
        event("mix-5", "heartbeat", at=ahead),  # clock ahead of the server's
        event("mix-6", "axle_count", section="BC", axles=4),  # not this device's section
        event("mix-7", "axle_count", section="AB", axles=4),
    ]
    results = _results(client, keys["B-ac"], items)
    assert [r["status"] for r in results] == ["created"] + ["rejected"] * 5 + ["created"]
    for item, result in zip(items[1:6], results[1:6], strict=True):
        if not isinstance(item, dict):
            assert result["event_id"] is None and result["error"]["status"] == 422
            continue
        alone = client.post(EVENTS, json=item, headers=keys["B-ac"])
        assert result["error"]["status"] == alone.status_code == 422, alone.text
        assert result["error"]["detail"][:20] == alone.json()["detail"][:20]
        assert result["error"]["errors"] == alone.json()["errors"]
    assert results[1]["error"]["errors"][0]["loc"] == ["body", "axles"]
    assert [r.event_id for r in _stored(session, "mix-")] == ["mix-1", "mix-7"]


def test_an_all_valid_batch_with_a_clock_ahead_refuses_that_item_only(
    client: TestClient, session: Session
) -> None:
    """Every item passes the schema, so the one-pass validation succeeds; the clock is still
    checked item by item."""
    keys = build_line(client)
    ahead = (datetime.now(UTC) + timedelta(hours=2)).isoformat()
    items = [event("clk-1", "heartbeat"), event("clk-2", "heartbeat", at=ahead)]
    results = _results(client, keys["B-ac"], items)
    assert [r["status"] for r in results] == ["created", "rejected"]
    assert "ahead of the server's clock" in results[1]["error"]["detail"]
    assert [r.event_id for r in _stored(session, "clk-")] == ["clk-1"]


def test_a_batch_with_events_stored_before(client: TestClient, session: Session) -> None:
    """Events sent alone first, then again inside a batch with new ones: the stored ones are
    answered from their stored results (another spelling is the same event), a changed one
    is refused, the new ones are stored, nothing twice."""
    keys = build_line(client)
    first = [event(f"old-{i}", "axle_count", section="AB", axles=4 * i) for i in range(3)]
    answers = [client.post(EVENTS, json=body, headers=keys["B-ac"]) for body in first]
    assert [a.status_code for a in answers] == [201] * 3
    items = [
        event("old-new-1", "heartbeat"),
        first[0],
        {**first[1], "axles": 99},
        {**first[2], "occurred_at": "2026-11-23T10:15:00+00:00"},
        event("old-new-2", "axle_count", section="AB", axles=16),
    ]
    results = _results(client, keys["B-ac"], items)
    assert [r["status"] for r in results] == [
        "created",
        "duplicate",
        "rejected",
        "duplicate",
        "created",
    ]
    assert results[1]["result"] == {**answers[0].json(), "status": "duplicate"}
    assert results[3]["result"] == {**answers[2].json(), "status": "duplicate"}
    assert results[2]["error"]["status"] == 409
    stored = [r.event_id for r in _stored(session, "old-")]
    assert sorted(stored) == ["old-0", "old-1", "old-2", "old-new-1", "old-new-2"]
    # Sent again as a whole: every item the same answer, nothing stored twice.
    again = _results(client, keys["B-ac"], items)
    assert [r["status"] for r in again] == ["duplicate"] * 2 + ["rejected"] + ["duplicate"] * 2
    assert session.scalar(
        select(func.count()).select_from(RawEvent).where(RawEvent.event_id.like("old-%"))
    ) == len(stored)


def test_the_batch_insert_writes_the_rows_a_single_event_writes(
    client: TestClient, session: Session
) -> None:
    """The one-statement insert (a JSON document unpacked by the database on PostgreSQL) keeps
    every column as the single-event insert does: the body as received (text beyond ASCII, key
    order), the time with its offset's instant and microseconds, the section, the answer."""
    keys = build_line(client)
    sent = {
        "T-obu": {"occurred_at": "2026-11-23T12:15:00.123456+02:00", "kind": "motion_sample",
                  "train": "Бірзула-7", "t": 1300.5, "accel_mps2": -0.42},
        "B-ac": {"occurred_at": "2026-11-23T10:15:00.5Z", "kind": "axle_count",
                 "section": "AB", "axles": 8},
    }  # fmt: skip
    for device, shape in sent.items():
        alone = client.post(EVENTS, json={"event_id": f"row-a-{device}", **shape},
                            headers=keys[device])  # fmt: skip
        assert alone.status_code == 201, alone.text
        results = _results(client, keys[device], [{"event_id": f"row-b-{device}", **shape}])
        assert results[0]["status"] == "created"
        (single,) = _stored(session, f"row-a-{device}")
        (batched,) = _stored(session, f"row-b-{device}")
        for column in ("device_id", "kind", "occurred_at", "section", "transport", "derive_error"):
            assert getattr(batched, column) == getattr(single, column), column
        assert list(batched.body) == ["event_id", *shape]
        assert batched.body == {**single.body, "event_id": f"row-b-{device}"}
        assert batched.result["event_id"] == f"row-b-{device}"
        assert batched.result.keys() == single.result.keys()
    (obu,) = _stored(session, "row-b-T-obu")
    assert obu.occurred_at == datetime(2026, 11, 23, 10, 15, 0, 123456, tzinfo=UTC)
    assert obu.body["train"] == "Бірзула-7" and obu.section is None


def test_the_idempotency_hash_is_the_one_stored_rows_carry() -> None:
    """The hash compares a retry with rows stored by earlier versions: its text is that of
    ``json.dumps`` (sorted keys, no spaces, UTF-8) of the event with every time as a UTC
    instant. Faster code must not change one byte of it."""
    from ingest.rows import event_sha256

    body = {"event_id": "h-1", "occurred_at": "2026-11-23T12:15:00.5+02:00",
            "kind": "train_departed", "section": "AB", "train": "Бірзула"}  # fmt: skip
    parsed = EVENT_ADAPTER.validate_python(body)
    reference = {
        "event_id": "h-1",
        "occurred_at": "2026-11-23T10:15:00.500000+00:00",
        "kind": "train_departed",
        "section": "AB",
        "train": "Бірзула",
        "eot_unit": None,
    }
    text = json.dumps(reference, sort_keys=True, separators=(",", ":"), ensure_ascii=False)
    assert event_sha256(parsed) == hashlib.sha256(text.encode()).hexdigest()


def _reference_hash(value: Any) -> str:
    """The idempotency hash as defined: ``json.dumps`` (sorted keys, no spaces, UTF-8) of
    ``model_dump()`` with every time, at any depth, as a UTC instant."""

    def instants(item: Any) -> Any:
        if isinstance(item, datetime):
            return item.astimezone(UTC).isoformat()
        if isinstance(item, dict):
            return {key: instants(inner) for key, inner in item.items()}
        if isinstance(item, list | tuple):
            return [instants(inner) for inner in item]
        return item

    text = json.dumps(instants(value), sort_keys=True, separators=(",", ":"), ensure_ascii=False)
    return hashlib.sha256(text.encode()).hexdigest()


def test_the_hash_of_every_kind_is_that_of_its_dump() -> None:
    """The hash reads an event's fields without ``model_dump`` (a batch's largest cost): for
    every kind it must be the hash of the dump, byte for byte, offsets and nesting included."""
    from ingest.rows import event_sha256
    from ingest.schemas import EVENT_KINDS
    from tests.service.test_service_events import EXAMPLES

    eot = event("h-eot", "eot_status", section="AB", unit_address=12345, pressure_psig=90)
    bodies = [body for _, body in EXAMPLES] + [eot]
    assert {b["kind"] for b in bodies} == set(EVENT_KINDS)
    for body in bodies:
        for at in ("2026-11-23T12:15:00.5+02:00", "2026-11-23T10:15:00Z"):
            parsed = EVENT_ADAPTER.validate_python({**body, "occurred_at": at})
            assert event_sha256(parsed) == _reference_hash(parsed.model_dump()), body["kind"]


def test_device_times_keep_their_offset_and_text() -> None:
    """A parsed time carries the standard library's timezone (faster to compare and convert
    than pydantic's own); the instant, the offset and its text are those sent."""
    for sent, text in (
        ("2026-11-23T10:15:00Z", "2026-11-23T10:15:00+00:00"),
        ("2026-11-23T12:15:00.250+02:00", "2026-11-23T12:15:00.250000+02:00"),
        ("2026-11-23T05:45:00-04:30", "2026-11-23T05:45:00-04:30"),
    ):
        at = EVENT_ADAPTER.validate_python(event("t", "heartbeat", at=sent)).occurred_at
        assert at.isoformat() == text
        assert at == datetime.fromisoformat(sent)
        assert type(at.tzinfo).__module__ == "datetime"

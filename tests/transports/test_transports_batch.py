"""One broker batch, handled in-process on the line's database: every bad message gets its own
answer and leaves the others stored; a batch that fails together is redone message by
message; a database that fails acknowledges nothing."""

from __future__ import annotations

import json
from collections.abc import Iterator
from datetime import timedelta
from typing import Any

import httpx
import pytest
from sqlalchemy import create_engine, text
from sqlalchemy.exc import OperationalError
from sqlalchemy.orm import Session, sessionmaker

from core.auth import device_cache
from service import features
from tests.reliability.conftest import ADMIN_HEADERS
from tests.transports.conftest import Line
from transports import envelope
from transports.envelope import Message, handle_batch

LIMIT = 4096
SENDER, OTHER = "T1-obu", "T2-obu"
UNREACHABLE = "postgresql+psycopg://postgres@127.0.0.1:1/nowhere"  # nothing listens on port 1


def _heartbeat(event_id: str, **fields: Any) -> bytes:
    return json.dumps({"event_id": event_id, "kind": "heartbeat",
                       "occurred_at": "2026-11-23T03:00:00Z", **fields}).encode()  # fmt: skip


@pytest.fixture
def sessions(line: Line) -> Iterator[sessionmaker[Session]]:
    features.install()
    engine = create_engine(line.database_url)
    yield sessionmaker(engine)
    engine.dispose()


def _keys(line: Line) -> dict[str, str]:
    return {d.id: d.key for d in line.devices}


def _stored(line: Line, like: str) -> list[str]:
    engine = create_engine(line.database_url)
    with engine.connect() as connection:
        rows = connection.execute(
            text("SELECT event_id FROM raw_events WHERE event_id LIKE :p ORDER BY event_id"),
            {"p": like},
        ).all()
    engine.dispose()
    return [r[0] for r in rows]


def test_bad_messages_in_one_batch_disturb_nothing(
    line: Line, sessions: sessionmaker[Session]
) -> None:
    key, other = _keys(line)[SENDER], _keys(line)[OTHER]
    batch = [
        Message(SENDER, key, _heartbeat("bad-batch-1")),
        Message(SENDER, other, _heartbeat("bad-batch-wrongkey")),
        Message(SENDER, None, _heartbeat("bad-batch-nokey")),
        Message(SENDER, key, b"{not json"),
        Message(SENDER, key, _heartbeat("bad-batch-tea", kind="tea")),
        Message(SENDER, key, b'{"pad": "' + b"x" * LIMIT + b'"}'),
        Message(SENDER, key, _heartbeat("bad-batch-dep", kind="train_departed", section="S0S1",
                                         train="1")),
        Message(SENDER, key, _heartbeat("bad-batch-1")),  # a redelivery in the same batch
        Message(SENDER, key, _heartbeat("bad-batch-1", occurred_at="2026-11-23T03:00:01Z")),
        Message(OTHER, other, json.dumps({"events": [json.loads(_heartbeat("bad-batch-2")),
                                                     {"kind": "tea"}]}).encode()),
        Message(OTHER, other, json.dumps({"events": []}).encode()),
        Message(SENDER, key, _heartbeat("bad-batch-3")),
    ]  # fmt: skip
    answers = handle_batch(sessions, batch, transport="mqtt", max_bytes=LIMIT)
    assert [a.status for a in answers] == [201, 401, 401, 422, 422, 413, 403, 200, 409, 200,
                                           422, 201]  # fmt: skip
    assert not any(a.retry for a in answers)
    assert answers[7].body["status"] == "duplicate"
    assert answers[4].body["event_id"] == "bad-batch-tea" and answers[4].body["detail"]
    items = answers[9].body["results"]
    assert [i["status"] for i in items] == ["created", "rejected"]
    assert items[1]["error"]["status"] == 422
    for answer in answers:
        assert json.loads(answer.to_json())["http_status"] == answer.status
    assert _stored(line, "bad-batch-%") == ["bad-batch-1", "bad-batch-2", "bad-batch-3"]


def test_a_batch_that_fails_together_is_redone_message_by_message(
    line: Line, sessions: sessionmaker[Session], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The together path fails for one device (as a value the database refuses would):
    the others are still stored once, and only the message that fails by itself is
    answered 500 (unacknowledged over NATS, to come again)."""
    real = envelope.accept_batches

    def poisoned(session: Session, batches: Any, **kw: Any) -> Any:
        """Fails whenever the poisoned event is among those stored: the whole batch first,
        then that message by itself."""
        if any(i.get("event_id") == "bad-redo-poison" for b in batches for i in b.items):
            raise ValueError("poisoned")
        return real(session, batches, **kw)

    monkeypatch.setattr(envelope, "accept_batches", poisoned)
    key, other = _keys(line)[SENDER], _keys(line)[OTHER]
    batch = [
        Message(SENDER, key, _heartbeat("bad-redo-1")),
        Message(OTHER, other, _heartbeat("bad-redo-2")),
        Message(OTHER, other, _heartbeat("bad-redo-poison")),
        Message(SENDER, key, b"[1"),
    ]
    answers = handle_batch(sessions, batch, transport="nats", max_bytes=LIMIT)
    assert [(a.status, a.retry) for a in answers] == [
        (201, False), (201, False), (500, True), (422, False)
    ]  # fmt: skip
    assert _stored(line, "bad-redo-%") == ["bad-redo-1", "bad-redo-2"]


def test_database_down_raises_so_nothing_is_acknowledged(line: Line) -> None:
    engine = create_engine(UNREACHABLE)
    key = _keys(line)[SENDER]
    with pytest.raises(OperationalError):
        handle_batch(
            sessionmaker(engine),
            [Message(SENDER, key, _heartbeat("bad-down-1"))],
            transport="mqtt",
            max_bytes=LIMIT,
        )
    engine.dispose()


def test_decommissioned_device_is_refused_as_over_http(
    line: Line, sessions: sessionmaker[Session]
) -> None:
    like = next(d for d in line.devices if d.id == SENDER)
    body = {"id": "bad-decom-obu", "station": like.station, "kind": like.kind}
    if like.section is not None:
        body["section"] = like.section
    api = f"{line.servers[0].url}/api/v1"
    created = httpx.post(f"{api}/devices", json=body, headers=ADMIN_HEADERS)
    assert created.status_code == 201, created.text
    key = created.json()["key"]
    message = Message("bad-decom-obu", key, _heartbeat("bad-decom-1"))
    assert handle_batch(sessions, [message], transport="mqtt", max_bytes=LIMIT)[0].status == 201
    gone = httpx.post(f"{api}/devices/bad-decom-obu/decommission", headers=ADMIN_HEADERS)
    assert gone.status_code == 200, gone.text
    device_cache().invalidate("bad-decom-obu")  # as the worker that decommissions it does
    message = Message("bad-decom-obu", key, _heartbeat("bad-decom-2"))
    (answer,) = handle_batch(sessions, [message], transport="mqtt", max_bytes=LIMIT)
    assert answer.status == 401 and answer.body["detail"], answer.body  # its key was replaced
    assert _stored(line, "bad-decom-%") == ["bad-decom-1"]


def _refusals(line: Line) -> list[tuple[Message, int, dict[str, Any]]]:
    """(message, http_status, what the refusal must name) for every refusal whose payload can
    be read far enough to name its event; what cannot be read names the device alone."""
    key, other = _keys(line)[SENDER], _keys(line)[OTHER]
    batch = json.dumps({"events": [json.loads(_heartbeat("ids-b1")), {"kind": "heartbeat"}]})
    return [
        (Message(SENDER, other, _heartbeat("ids-wrongkey")), 401, {"event_id": "ids-wrongkey"}),
        (Message(SENDER, None, _heartbeat("ids-nokey")), 401, {"event_id": "ids-nokey"}),
        (Message(SENDER, key, _heartbeat("ids-tea", kind="tea")), 422, {"event_id": "ids-tea"}),
        (Message(SENDER, key, _heartbeat("ids-when", occurred_at="soon")), 422,
         {"event_id": "ids-when"}),
        (Message(SENDER, key, _heartbeat("ids-extra", colour="red")), 422,
         {"event_id": "ids-extra"}),
        (Message(SENDER, other, batch.encode()), 401, {"event_ids": ["ids-b1", None]}),
        (Message(SENDER, key, b"{not json"), 422, {}),
        (Message(SENDER, key, b'{"pad": "' + b"x" * LIMIT + b'"}'), 413, {}),
    ]  # fmt: skip


@pytest.mark.parametrize("path", ["together", "one by one"])
def test_refusals_name_the_event_and_the_device_when_readable(
    line: Line,
    sessions: sessionmaker[Session],
    monkeypatch: pytest.MonkeyPatch,
    caplog: pytest.LogCaptureFixture,
    path: str,
) -> None:
    """A device matches an answer to its message by event_id: every refusal names it when the
    payload is JSON with one (a wrong key too), and names the device, on either path."""
    if path == "one by one":

        def failing(*_: Any, **__: Any) -> Any:
            raise ValueError("the batch fails together")

        monkeypatch.setattr(envelope, "_grouped", failing)
    cases = _refusals(line)
    answers = handle_batch(sessions, [m for m, _, _ in cases], transport="mqtt", max_bytes=LIMIT)
    for (message, status, names), answer in zip(cases, answers, strict=True):
        body = json.loads(answer.to_json())
        assert body["http_status"] == status and body["detail"], body
        assert body["device"] == message.device_id, body
        for field in ("event_id", "event_ids"):
            assert body.get(field) == names.get(field), (field, body)
    assert _stored(line, "ids-%") == []
    redone = "failed together" in caplog.text
    assert redone == (path == "one by one"), caplog.text  # refusals alone never cost the batch


def test_a_value_only_the_database_refuses_is_refused_alone(
    line: Line, sessions: sessionmaker[Session], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A value the validation lets through and PostgreSQL refuses (an offset past ±15:59, with
    the validation's own bound widened to let it through) is that message's 422, final (not
    500 to come again for ever), and inside a message's ``{"events": [...]}`` that item's
    alone: the batch's other events are stored (they were refused with it)."""
    if not line.database_url.startswith("postgresql"):
        pytest.skip("SQLite stores any offset: the database refuses nothing here")
    monkeypatch.setattr("ingest.field_types.EASTMOST_OFFSET", timedelta(hours=23, minutes=59))
    key = _keys(line)[SENDER]
    odd = _heartbeat("bad-db-odd", occurred_at="2026-11-23T19:00:00+16:00")
    events = [json.loads(_heartbeat(f"bad-db-b{n}")) for n in (1, 3)]
    batch = [
        Message(SENDER, key, _heartbeat("bad-db-1")),
        Message(SENDER, key, odd),
        Message(SENDER, key, json.dumps({"events": [events[0], json.loads(odd), events[1]]})
                .encode()),
    ]  # fmt: skip
    answers = handle_batch(sessions, batch, transport="mqtt", max_bytes=LIMIT)
    assert [(a.status, a.retry) for a in answers] == [(201, False), (422, False), (200, False)]
    assert "cannot be stored" in answers[1].body["detail"], answers[1].body
    items = answers[2].body["results"]
    assert [i["status"] for i in items] == ["created", "rejected", "created"]
    assert _stored(line, "bad-db-%") == ["bad-db-1", "bad-db-b1", "bad-db-b3"]
